// `gearwatch twin state --db FILE [--format table|json]`: what the model thread knows now (docs/model.md):
// K_wear, K_pitting, wear depth (mean and root -> tip), pitting density (mean and distribution), the
// update history, the latest prediction, and wear-depth inspections against the prediction.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "gearwatch/storage/inspections.hpp"
#include "gearwatch/storage/model_history.hpp"
#include "model_thread.hpp"

namespace gearwatch::cli {
namespace {

using nlohmann::json;

json json_of(const storage::StoredValue& v) {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return *i;
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* t = std::get_if<std::string>(&v)) return *t;
  if (const auto* b = std::get_if<storage::Blob>(&v)) return b->bytes;
  return nullptr;
}

json rows(const storage::StoredTable& table) {
  json out = json::array();
  for (const auto& r : table.rows) {
    json row = json::object();
    for (std::size_t i = 0; i < table.columns.size(); ++i) row[table.columns[i]] = json_of(r[i]);
    out.push_back(std::move(row));
  }
  return out;
}

json inspection_json(const storage::StoredInspection& i) {
  auto optional = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"id", i.id}, {"cycles", i.cycles}, {"wear_depth_m", optional(i.wear_depth_m)},
          {"wear_depth_max_m", optional(i.wear_depth_max_m)}, {"wear_depth_relative_sd", optional(i.wear_depth_relative_sd)},
          {"pitted_area_fraction", optional(i.pitted_area_fraction)}, {"note", i.note.empty() ? json(nullptr) : json(i.note)}};
}

std::string num(const json& v, const char* f = "%.4g", double scale = 1.0) {
  if (!v.is_number()) return "-";
  char b[48];
  std::snprintf(b, sizeof b, f, v.get<double>() * scale);
  return b;
}

// The command's steps: read the model's newest state, add what storage holds around it (updates,
// prediction, inspections against the prediction), then print it as JSON or as a table.
class TwinStateCommand {
 public:
  explicit TwinStateCommand(const std::string& db_path) : db_(open_history(db_path)) {}

  json collect() {
    try {
      const storage::StoredModelState stored = newest_state();
      const wear::ModelMemory m = memory_of(stored);
      origin_cycles_ = pair_of(stored).origin_cycles;
      json out = state_json(stored, m);
      out["pair"] = pair_json(pair_of(stored));
      out["updates"] = rows(storage::load_gear_pair_k_updates(db_, stored.gear_pair));
      out["prediction"] = newest_prediction(stored.gear_pair);
      out["inspections"] = inspections_against_prediction(stored.gear_pair);
      return out;
    } catch (const storage::SqliteError& e) {
      throw CommandError(std::string("twin state: ") + e.what());
    }
  }

  static void print_table(const json& out) {
    print_model(out);
    print_profile(out["wear"], out["pitting"]);
    print_updates(out["updates"]);
    if (out["prediction"].is_object()) print_prediction(out["prediction"]);
    if (!out["inspections"].empty()) print_inspections(out["inspections"]);
  }

 private:
  storage::StoredModelState newest_state() {
    if (!storage::has_model_state(db_)) throw CommandError("twin state: this database has no model state (written before schema version 4)");
    std::optional<storage::StoredModelState> stored = storage::load_newest_model_state(db_);
    if (!stored) throw CommandError("twin state: the model has not handled a record yet");
    return *stored;
  }

  static wear::ModelMemory memory_of(const storage::StoredModelState& stored) {
    try {
      return daemon::memory_from_json(stored.state_json);
    } catch (const std::exception& e) {
      throw CommandError(std::string("twin state: ") + e.what());
    }
  }

  static daemon::PairStart pair_of(const storage::StoredModelState& stored) {
    try {
      return daemon::pair_start_from_json(stored.state_json);
    } catch (const std::exception& e) {
      throw CommandError(std::string("twin state: ") + e.what());
    }
  }

  static json pair_json(const daemon::PairStart& p) {
    return {{"origin_life_counter", p.origin_cycles},
            {"start_reason", p.reason.empty() ? json(nullptr) : json(p.reason)},
            {"gears", p.gears ? json(daemon::gear_pair_text(*p.gears)) : json(nullptr)}};
  }

  static json state_json(const storage::StoredModelState& stored, const wear::ModelMemory& m) {
    const wear::WearState& s = m.current.state;
    const wear::WearSummary sum = wear::summarise(s);
    double max_depth = 0;
    for (double d : s.pinion_depth_m) max_depth = std::max(max_depth, d);
    for (double d : s.gear_depth_m) max_depth = std::max(max_depth, d);
    json fraction = json::array();
    for (std::size_t j = 0; j < s.pinion_depth_m.size(); ++j)
      fraction.push_back(s.pinion_depth_m.size() > 1 ? static_cast<double>(j) / static_cast<double>(s.pinion_depth_m.size() - 1) : 0.0);
    json out = {{"gear_pair", stored.gear_pair},
                {"updated_at", stored.updated_at},
                {"cycles", s.cycles},
                {"k_wear_si", m.k_wear_si},
                {"k_wear_seed_unit", wear::k_wear_seed_from_si(m.k_wear_si)},
                {"k_pitting", m.k_pitting},
                {"k_wear_updates", m.k_wear_updates},
                {"k_pitting_updates", m.k_pitting_updates},
                {"pitting_calibrated", m.pitting_calibrated},
                {"wear", {{"pinion_mean_m", sum.pinion_mean_depth_m}, {"gear_mean_m", sum.gear_mean_depth_m},
                          {"combined_mean_m", sum.combined_mean_depth_m}, {"max_m", max_depth}, {"pinion_share", sum.pinion_share},
                          {"profile_fraction", fraction}, {"combined_depth_m", wear::combined_profile(s)},
                          {"pinion_depth_m", s.pinion_depth_m}, {"gear_depth_m", s.gear_depth_m}}},
                {"pitting", {{"mean", sum.mean_pitting_density}, {"max", sum.max_pitting_density},
                             {"max_profile_fraction", sum.max_pitting_fraction}, {"pinion_pitting", s.pinion_pitting}}}};
    if (m.ics2_scale_valid)
      out["ics2_scale"] = {{"form", wear::to_string(m.ics2_scale_form)}, {"ics2", m.ics2_scale_ics2}, {"density", m.ics2_scale_density},
                           {"slope", m.ics2_scale_slope}, {"baseline", m.ics2_scale_baseline}};
    return out;
  }

  json newest_prediction(std::int64_t pair) {
    json latest = rows(storage::load_newest_prediction(db_, pair));
    if (latest.empty()) return nullptr;
    if (const auto curve = storage::load_forecast_curve(db_, latest[0]["run_id"].get<std::int64_t>()))
      latest[0]["forecast_curve"] = json::parse(*curve);
    return latest[0];
  }

  // Wear-depth inspections against the model's mean depth at their cycles (between the two runs
  // around them; the model's depth is linear enough between neighbouring records).
  json inspections_against_prediction(std::int64_t pair) {
    std::vector<storage::StoredInspection> stored = storage::load_gear_pair_inspections(db_, pair);
    std::stable_sort(stored.begin(), stored.end(), [](const auto& a, const auto& b) { return a.cycles < b.cycles; });
    json inspections = json::array();
    for (const auto& stored_inspection : stored) {
      json i = inspection_json(stored_inspection);
      add_prediction_at(i, pair);
      inspections.push_back(std::move(i));
    }
    return inspections;
  }

  // An inspection's cycles are the life counter's; the model's are the pair's (from its origin).
  void add_prediction_at(json& i, std::int64_t pair) {
    const double c = i["cycles"].get<double>() - origin_cycles_;
    const std::vector<storage::PredictionPoint> near = storage::load_predictions_nearest(db_, pair, c, 2);
    std::vector<std::array<double, 3>> pts;
    for (const auto& p : near) pts.push_back({p.cycles, p.wear_mean_m, p.pitting_mean});
    if (pts.empty()) return;
    auto at = [&](int k) {
      if (pts.size() < 2 || pts[0][0] == pts[1][0]) return pts[0][k];
      const double t = (c - pts[0][0]) / (pts[1][0] - pts[0][0]);
      return pts[0][k] + std::clamp(t, 0.0, 1.0) * (pts[1][k] - pts[0][k]);
    };
    i["predicted_wear_mean_m"] = at(1);
    i["predicted_pitting_mean"] = at(2);
    if (i["wear_depth_m"].is_number() && i["wear_depth_m"].get<double>() > 0)
      i["wear_error_pct"] = 100.0 * (at(1) / i["wear_depth_m"].get<double>() - 1.0);
  }

  static void print_model(const json& out) {
    std::printf("gear pair %lld at %.6g cycles (state of %s)\n", static_cast<long long>(out["gear_pair"].get<std::int64_t>()),
                out["cycles"].get<double>(), out["updated_at"].get<std::string>().c_str());
    const json& p = out["pair"];
    if (p["gears"].is_string()) std::printf("gears     %s\n", p["gears"].get<std::string>().c_str());
    if (p["start_reason"].is_string())
      std::printf("started   at life counter %.0f (its cycle 0): %s\n", p["origin_life_counter"].get<double>(),
                  p["start_reason"].get<std::string>().c_str());
    std::printf("K_wear    %.5g m^2/N (%.5g in the thesis's unit), %llu updates\n", out["k_wear_si"].get<double>(),
                out["k_wear_seed_unit"].get<double>(), static_cast<unsigned long long>(out["k_wear_updates"].get<std::uint64_t>()));
    std::printf("K_pitting %.5g (%s), %llu updates\n", out["k_pitting"].get<double>(),
                out["pitting_calibrated"].get<bool>() ? "calibrated from inspections" : "not calibrated: needs two pitted-area inspections",
                static_cast<unsigned long long>(out["k_pitting_updates"].get<std::uint64_t>()));
  }

  static void print_profile(const json& w, const json& p) {
    std::printf("wear depth: combined mean %s um (pinion %s, gear %s), deepest %s um\n", num(w["combined_mean_m"], "%.3f", 1e6).c_str(),
                num(w["pinion_mean_m"], "%.3f", 1e6).c_str(), num(w["gear_mean_m"], "%.3f", 1e6).c_str(), num(w["max_m"], "%.3f", 1e6).c_str());
    std::printf("pitting density: mean %s %%, max %s %% at profile fraction %s\n", num(p["mean"], "%.3f", 100).c_str(),
                num(p["max"], "%.3f", 100).c_str(), num(p["max_profile_fraction"], "%.2f").c_str());
    std::printf("\n%-9s %14s %14s %14s %10s\n", "fraction", "combined_um", "pinion_um", "gear_um", "pitting_%");
    const auto n = w["combined_depth_m"].size();
    for (int k = 0; k <= 10 && n > 1; ++k) {
      const auto j = static_cast<std::size_t>(std::lround(k / 10.0 * static_cast<double>(n - 1)));
      std::printf("%-9.2f %14.3f %14.3f %14.3f %10.3f\n", k / 10.0, w["combined_depth_m"][j].get<double>() * 1e6,
                  w["pinion_depth_m"][j].get<double>() * 1e6, w["gear_depth_m"][j].get<double>() * 1e6,
                  p["pinion_pitting"][j].get<double>() * 100);
    }
  }

  static void print_updates(const json& updates) {
    std::printf("\nupdates (%zu):\n", updates.size());
    for (const auto& u : updates)
      std::printf("  %s at %s cycles: %s %s %s -> %s (%s)\n", u["created_at"].get<std::string>().c_str(), num(u["cycles"], "%.6g").c_str(),
                  u["kind"].get<std::string>().c_str(), u["outcome"].get<std::string>().c_str(), num(u["old_value"], "%.5g").c_str(),
                  num(u["new_value"], "%.5g").c_str(), u["evidence"].get<std::string>().c_str());
  }

  static void print_prediction(const json& pr) {
    std::printf("\nprediction at %s cycles (%s Hz, %s N m):\n", num(pr["cycles"], "%.6g").c_str(), num(pr["forecast_speed_hz"]).c_str(),
                num(pr["forecast_torque_nm"]).c_str());
    std::printf("  combined mean depth %s um [%s, %s] (the interval spans the profile shapes RMS_SA cannot tell apart)\n",
                num(pr.value("wear_mean_m", json()), "%.3f", 1e6).c_str(), num(pr.value("wear_mean_low_m", json()), "%.3f", 1e6).c_str(),
                num(pr.value("wear_mean_high_m", json()), "%.3f", 1e6).c_str());
    if (!pr.value("wear_depth_ratio", json()).is_null())
      std::printf("  calibrated by %s inspected wear depths: rho %s (ln SD %s), combined mean depth %s um (the interval above is rho's)\n",
                  num(pr["wear_depth_inspections"], "%.0f").c_str(), num(pr["wear_depth_ratio"], "%.4g").c_str(),
                  num(pr["wear_depth_ratio_log_sd"], "%.3g").c_str(), num(pr["wear_mean_estimate_m"], "%.3f", 1e6).c_str());
    if (!pr.value("wear_peak_ratio", json()).is_null())
      std::printf("  %s inspected deepest points: deepest / mean %s (ln P mean %s, SD %s)\n", num(pr["wear_peak_inspections"], "%.0f").c_str(),
                  num(pr["wear_peak_ratio"], "%.4g").c_str(), num(pr["wear_peak_ratio_log_mean"], "%.4g").c_str(),
                  num(pr["wear_peak_ratio_log_sd"], "%.3g").c_str());
    std::printf("  wear depth %s mm limit: %s cycles left [%s, %s]\n", num(pr["wear_limit_m"], "%.3f", 1e3).c_str(),
                num(pr["wear_cycles_left"], "%.4g").c_str(), num(pr["wear_cycles_left_low"], "%.4g").c_str(),
                num(pr["wear_cycles_left_high"], "%.4g").c_str());
    std::printf("  pitting density %s %% limit: %s cycles left [%s, %s]\n", num(pr["pitting_limit"], "%.3g", 100).c_str(),
                num(pr["pitting_cycles_left"], "%.4g").c_str(), num(pr["pitting_cycles_left_low"], "%.4g").c_str(),
                num(pr["pitting_cycles_left_high"], "%.4g").c_str());
    std::printf("  (- = not within the forecast horizon)\n");
  }

  static void print_inspections(const json& inspections) {
    std::printf("\ninspections against the prediction:\n");
    for (const auto& i : inspections)
      std::printf("  at %s cycles: wear %s um (model %s um, %s %%), pitted area %s %% (model %s %%)\n", num(i["cycles"], "%.6g").c_str(),
                  num(i["wear_depth_m"], "%.3f", 1e6).c_str(), num(i.value("predicted_wear_mean_m", json()), "%.3f", 1e6).c_str(),
                  num(i.value("wear_error_pct", json()), "%+.1f").c_str(), num(i["pitted_area_fraction"], "%.3f", 100).c_str(),
                  num(i.value("predicted_pitting_mean", json()), "%.3f", 100).c_str());
  }

  storage::Database db_;
  double origin_cycles_ = 0;  ///< life counter at the pair's cycle 0
};

}  // namespace

void register_twin_state(CLI::App* twin) {
  struct Options {
    std::string db, format = "table";
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = twin->add_subcommand("state", "The model's current K values, wear, pitting, updates and predictions");
  cmd->add_option("--db", opt->db, "SQLite database written by `run` or `replay`")->required();
  add_format_option(cmd, opt->format, "table", {"table", "json"});
  cmd->callback([opt] {
    const json out = TwinStateCommand(opt->db).collect();
    if (opt->format == "json")
      std::cout << dump_json(out) << "\n";
    else
      TwinStateCommand::print_table(out);
  });
}

}  // namespace gearwatch::cli
