#include "gearwatch/storage/gap_reports.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "json_numbers.hpp"
#include "stored_tokens.hpp"

namespace gearwatch::storage {
namespace {

using nlohmann::json;
using detail::kNaN;

template <class Enum, std::size_t N>
Enum token_to_enum(const std::array<Enum, N>& all, const std::string& token, const char* domain, std::int64_t report_id) {
  return detail::enum_of(all, token, domain, "gap report " + std::to_string(report_id));
}

gap::FamilyKind family_of(const std::string& token, std::int64_t id) {
  return token_to_enum(gap::kAllFamilyKinds, token, "gap family", id);
}
gap::CandidateEffect effect_of(const std::string& token, std::int64_t id) {
  return token_to_enum(gap::kAllCandidateEffects, token, "gap effect", id);
}

// JSON has no NaN or infinity: they are written as null and read back as NaN.
using detail::json_number;
using detail::number_from_json;
using detail::json_numbers;
using detail::numbers_from_json;


json bands(const std::vector<std::pair<gap::FamilyKind, gap::Interval>>& list) {
  json a = json::array();
  for (const auto& [family, interval] : list) a.push_back({gap::to_string(family), json_number(interval.low), json_number(interval.high)});
  return a;
}
std::vector<std::pair<gap::FamilyKind, gap::Interval>> bands_from(const json& j, std::int64_t id) {
  std::vector<std::pair<gap::FamilyKind, gap::Interval>> out;
  for (const auto& b : j) out.emplace_back(family_of(b.at(0).get<std::string>(), id), gap::Interval{number_from_json(b.at(1)), number_from_json(b.at(2))});
  return out;
}

gap::FeatureMovement movement_of(const std::string& token, std::int64_t id) {
  return token_to_enum(gap::kAllFeatureMovements, token, "feature movement", id);
}
gap::FeatureShaft shaft_of(const std::string& token, std::int64_t id) {
  return token_to_enum(gap::kAllFeatureShafts, token, "feature shaft", id);
}

json description_json(const gap::FeatureDescription& d) {
  json parameters = json::array();
  for (const auto& [name, value] : d.parameters) parameters.push_back({name, json_number(value)});
  return {{"kind", gap::to_string(d.kind)}, {"shaft", gap::to_string(d.shaft)}, {"parameters", parameters},
          {"gap_db", json_number(d.gap_db)}, {"residual_db", json_number(d.residual_db)}};
}

gap::FeatureDescription description_from(const json& j, std::int64_t id) {
  gap::FeatureDescription d;
  d.kind = token_to_enum(gap::kAllDescriptionKinds, j.at("kind").get<std::string>(), "feature description", id);
  d.shaft = shaft_of(j.at("shaft").get<std::string>(), id);
  for (const auto& p : j.at("parameters")) d.parameters.emplace_back(p.at(0).get<std::string>(), number_from_json(p.at(1)));
  d.gap_db = number_from_json(j.at("gap_db"));
  d.residual_db = number_from_json(j.at("residual_db"));
  return d;
}

// A feature's numbers by their stored names: features_json writes and features_from reads this one list.
constexpr std::array<std::pair<const char*, double gap::GapFeature::*>, 8> kFeatureNumbers{{
    {"order", &gap::GapFeature::order},
    {"order_low", &gap::GapFeature::order_low},
    {"order_high", &gap::GapFeature::order_high},
    {"hz", &gap::GapFeature::hz},
    {"hz_low", &gap::GapFeature::hz_low},
    {"hz_high", &gap::GapFeature::hz_high},
    {"size_db", &gap::GapFeature::size_db},
    {"p_value", &gap::GapFeature::p_value},
}};

json features_json(const std::vector<gap::GapFeature>& features) {
  json a = json::array();
  for (const auto& f : features) {
    json seen = json::array();
    for (const auto& s : f.seen_in)
      seen.push_back({{"held_out", s.held_out}, {"record", s.record}, {"speed_hz", json_number(s.speed_hz)},
                      {"torque_nm", json_number(s.torque_nm)}, {"order", json_number(s.order)}, {"hz", json_number(s.hz)},
                      {"size_db", json_number(s.size_db)}});
    json feature = {{"movement", gap::to_string(f.movement)}, {"shaft", gap::to_string(f.shaft)},
                    {"size_interval_db", {json_number(f.size_interval_db.low), json_number(f.size_interval_db.high)}},
                    {"seen_in", seen}, {"description", description_json(f.description)},
                    {"explained_by", f.explained_by ? json(gap::to_string(*f.explained_by)) : json(nullptr)}};
    for (const auto& [name, member] : kFeatureNumbers) feature[name] = json_number(f.*member);
    a.push_back(std::move(feature));
  }
  return a;
}

std::vector<gap::GapFeature> features_from(const json& a, std::int64_t id) {
  std::vector<gap::GapFeature> out;
  for (const auto& j : a) {
    gap::GapFeature f;
    f.movement = movement_of(j.at("movement").get<std::string>(), id);
    f.shaft = shaft_of(j.at("shaft").get<std::string>(), id);
    for (const auto& [name, member] : kFeatureNumbers) f.*member = number_from_json(j.at(name));
    f.size_interval_db = {number_from_json(j.at("size_interval_db").at(0)), number_from_json(j.at("size_interval_db").at(1))};
    for (const auto& s : j.at("seen_in"))
      f.seen_in.push_back({s.at("held_out").get<bool>(), s.at("record").get<std::size_t>(), number_from_json(s.at("speed_hz")),
                           number_from_json(s.at("torque_nm")), number_from_json(s.at("order")), number_from_json(s.at("hz")),
                           number_from_json(s.at("size_db"))});
    // Features stored before descriptions were fitted carry none.
    if (const auto d = j.find("description"); d != j.end()) f.description = description_from(*d, id);
    if (const auto e = j.find("explained_by"); e != j.end() && !e->is_null()) f.explained_by = effect_of(e->get<std::string>(), id);
    out.push_back(std::move(f));
  }
  return out;
}

// The plot's spectra by their stored names: plot_json writes and plot_from reads this one list.
constexpr std::array<std::pair<const char*, std::vector<double> gap::GapReport::*>, 8> kPlotSpectra{{
    {"order_axis", &gap::GapReport::order_axis},
    {"measured_order_db", &gap::GapReport::measured_order_db},
    {"twin_order_db", &gap::GapReport::twin_order_db},
    {"twin_after_order_db", &gap::GapReport::twin_after_order_db},
    {"hz_axis", &gap::GapReport::hz_axis},
    {"measured_hz_db", &gap::GapReport::measured_hz_db},
    {"twin_hz_db", &gap::GapReport::twin_hz_db},
    {"twin_after_hz_db", &gap::GapReport::twin_after_hz_db},
}};

std::string plot_json(const gap::GapReport& r) {
  json plot{{"order_bands", bands(r.order_bands)}, {"hz_bands", bands(r.hz_bands)}, {"features", features_json(r.features)}};
  for (const auto& [name, member] : kPlotSpectra) plot[name] = json_numbers(r.*member);
  return plot.dump();
}

void plot_from(const std::string& text, gap::GapReport& r, std::int64_t id) {
  try {
    const json j = json::parse(text);
    for (const auto& [name, member] : kPlotSpectra) r.*member = numbers_from_json(j.at(name));
    r.order_bands = bands_from(j.at("order_bands"), id);
    r.hz_bands = bands_from(j.at("hz_bands"), id);
    // Reports stored before features were found carry none.
    if (const auto f = j.find("features"); f != j.end()) r.features = features_from(*f, id);
  } catch (const json::exception& e) {
    throw std::runtime_error("gap report " + std::to_string(id) + ": its plot spectra are not readable: " + e.what());
  }
}

// [name, value] per parameter, in the diagnosis's order; a parameter fitted at an end of its range
// carries two more: ["upper" or "lower", the end] (gap::ParameterBound). Readers of the two-element
// form read the first two of any entry.
std::string parameters_json(const std::vector<std::pair<std::string, double>>& parameters,
                            const std::vector<gap::ParameterBound>& bounds) {
  json a = json::array();
  std::vector<char> used(bounds.size(), 0);
  for (const auto& [name, value] : parameters) {
    json entry = {name, json_number(value)};
    for (std::size_t b = 0; b < bounds.size(); ++b)
      if (!used[b] && bounds[b].name == name) {
        entry.push_back(bounds[b].upper ? "upper" : "lower");
        entry.push_back(json_number(bounds[b].bound));
        used[b] = 1;
        break;
      }
    a.push_back(entry);
  }
  return a.dump();
}

void parameters_from(const std::string& text, std::int64_t id, gap::CandidateScore& c) {
  try {
    for (const auto& p : json::parse(text)) {
      c.parameters.emplace_back(p.at(0).get<std::string>(), number_from_json(p.at(1)));
      if (p.size() >= 4) c.at_bounds.push_back({p.at(0).get<std::string>(), number_from_json(p.at(3)), p.at(2).get<std::string>() == "upper"});
    }
  } catch (const json::exception& e) {
    throw std::runtime_error("gap report " + std::to_string(id) + ": candidate parameters are not readable: " + e.what());
  }
}

std::optional<double> optional_double(const Statement& s, int col) {
  if (s.is_null(col)) return std::nullopt;
  return s.get_double(col);
}
double double_or_nan(const Statement& s, int col) { return s.is_null(col) ? kNaN : s.get_double(col); }

// Binds the eight columns of a FamilyGap from `first` on: resolved, reason, distance, low, high,
// share, significant (position is bound by the caller).
void bind_gap(Statement& s, int first, const gap::FamilyGap& g) {
  s.bind(first, g.resolved ? 1 : 0);
  if (g.unresolved_reason.empty()) s.bind_null(first + 1);
  else s.bind(first + 1, g.unresolved_reason);
  s.bind(first + 2, g.distance_db).bind(first + 3, g.distance_interval_db.low).bind(first + 4, g.distance_interval_db.high)
      .bind(first + 5, g.energy_share).bind(first + 6, g.significant ? 1 : 0);
}

gap::FamilyGap read_gap(const Statement& s, int first, gap::FamilyKind family) {
  gap::FamilyGap g;
  g.family = family;
  g.resolved = s.get_int(first) != 0;
  g.unresolved_reason = s.is_null(first + 1) ? "" : s.get_text(first + 1);
  g.distance_db = double_or_nan(s, first + 2);
  g.distance_interval_db = {double_or_nan(s, first + 3), double_or_nan(s, first + 4)};
  g.energy_share = double_or_nan(s, first + 5);
  g.significant = s.get_int(first + 6) != 0;
  return g;
}

}  // namespace

bool has_gap_report_tables(Database& db) {
  Statement s(db, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'gap_report_runs'");
  return s.step();
}

std::int64_t count_gap_reports(Database& db) {
  Statement s(db, "SELECT count(*) FROM gap_report_runs");
  s.step();
  return s.get_int(0);
}

std::int64_t insert_gap_report(Database& db, const gap::GapReport& r, const GapReportContext& context) {
  json speeds = json::array();
  for (double v : r.speeds_hz) speeds.push_back(json_number(v));
  Statement run(db, "INSERT INTO gap_report_runs(record_id, gear_pair, input_revolutions, speeds_hz, training_records,"
                    " held_out_records, k_wear_before, k_wear_after, plot) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)");
  run.bind(1, context.record_id).bind(2, context.gear_pair).bind(3, r.input_revolutions).bind(4, speeds.dump())
      .bind(5, static_cast<std::uint64_t>(r.training_records)).bind(6, static_cast<std::uint64_t>(r.held_out_records))
      .bind(7, r.k_wear_before).bind(8, r.k_wear_after).bind(9, plot_json(r)).run();
  const std::int64_t id = db.last_insert_rowid();

  // One row per family: the before and after gaps side by side, and whether it is unexplained.
  struct FamilyRow {
    std::optional<std::size_t> before, after, unexplained;
  };
  std::map<gap::FamilyKind, FamilyRow> rows;
  for (std::size_t i = 0; i < r.before.size(); ++i) rows[r.before[i].family].before = i;
  for (std::size_t i = 0; i < r.after.size(); ++i) rows[r.after[i].family].after = i;
  for (std::size_t i = 0; i < r.unexplained.size(); ++i) rows[r.unexplained[i]].unexplained = i;
  Statement family(db, "INSERT INTO gap_report_families(report_id, family, before_position, before_resolved,"
                       " before_unresolved_reason, before_distance_db, before_interval_low_db, before_interval_high_db,"
                       " before_energy_share, before_significant, after_position, after_resolved, after_unresolved_reason,"
                       " after_distance_db, after_interval_low_db, after_interval_high_db, after_energy_share, after_significant,"
                       " unexplained_position) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (const auto& [kind, row] : rows) {
    for (int c = 3; c <= 19; ++c) family.bind_null(c);
    family.bind(1, id).bind(2, gap::to_string(kind));
    if (row.before) {
      family.bind(3, static_cast<std::uint64_t>(*row.before));
      bind_gap(family, 4, r.before[*row.before]);
    }
    if (row.after) {
      family.bind(11, static_cast<std::uint64_t>(*row.after));
      bind_gap(family, 12, r.after[*row.after]);
    }
    if (row.unexplained) family.bind(19, static_cast<std::uint64_t>(*row.unexplained));
    family.run();
  }

  Statement candidate(db, "INSERT INTO gap_report_candidates(report_id, rank, effect, shrinkage, information_criterion,"
                          " worsens_other_family, parameters) VALUES (?, ?, ?, ?, ?, ?, ?)");
  Statement candidate_family(db, "INSERT INTO gap_candidate_families(report_id, rank, family, explains_position, held_out_position,"
                                 " resolved, unresolved_reason, distance_db, interval_low_db, interval_high_db, energy_share,"
                                 " significant) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (std::size_t rank = 0; rank < r.candidates.size(); ++rank) {
    const gap::CandidateScore& c = r.candidates[rank];
    candidate.bind(1, id).bind(2, static_cast<std::uint64_t>(rank)).bind(3, gap::to_string(c.effect)).bind(4, c.shrinkage)
        .bind(5, c.information_criterion).bind(6, c.worsens_other_family ? 1 : 0).bind(7, parameters_json(c.parameters, c.at_bounds)).run();
    std::map<gap::FamilyKind, std::pair<std::optional<std::size_t>, std::optional<std::size_t>>> families;
    for (std::size_t i = 0; i < c.explains.size(); ++i) families[c.explains[i]].first = i;
    for (std::size_t i = 0; i < c.held_out_after.size(); ++i) families[c.held_out_after[i].family].second = i;
    for (const auto& [kind, positions] : families) {
      for (int col = 4; col <= 12; ++col) candidate_family.bind_null(col);
      candidate_family.bind(1, id).bind(2, static_cast<std::uint64_t>(rank)).bind(3, gap::to_string(kind));
      if (positions.first) candidate_family.bind(4, static_cast<std::uint64_t>(*positions.first));
      if (positions.second) {
        candidate_family.bind(5, static_cast<std::uint64_t>(*positions.second));
        bind_gap(candidate_family, 6, c.held_out_after[*positions.second]);
      }
      candidate_family.run();
    }
  }
  Statement chosen(db, "INSERT INTO gap_report_chosen(report_id, step, effect) VALUES (?, ?, ?)");
  for (std::size_t step = 0; step < r.chosen.size(); ++step)
    chosen.bind(1, id).bind(2, static_cast<std::uint64_t>(step)).bind(3, gap::to_string(r.chosen[step])).run();
  return id;
}

namespace {

// The runs of gap_report_runs (the newest `newest` of them when given), oldest first, without
// their families, candidates and chosen effects.
std::vector<StoredGapReport> load_gap_report_runs(Database& db, std::optional<std::size_t> newest) {
  std::vector<StoredGapReport> out;
  std::string sql = "SELECT id, created_at, record_id, gear_pair, input_revolutions, speeds_hz, training_records, held_out_records,"
                    " k_wear_before, k_wear_after, plot FROM gap_report_runs";
  if (newest) sql += " WHERE id IN (SELECT id FROM gap_report_runs ORDER BY id DESC LIMIT " + std::to_string(*newest) + ")";
  sql += " ORDER BY id";
  Statement s(db, sql);
  while (s.step()) {
    StoredGapReport g;
    g.id = s.get_int(0);
    g.created_at = s.get_text(1);
    if (!s.is_null(2)) g.context.record_id = s.get_int(2);
    g.context.gear_pair = s.get_int(3);
    gap::GapReport& r = g.report;
    r.input_revolutions = double_or_nan(s, 4);
    try {
      r.speeds_hz = numbers_from_json(json::parse(s.get_text(5)));
    } catch (const json::exception& e) {
      throw std::runtime_error("gap report " + std::to_string(g.id) + ": speeds are not readable: " + e.what());
    }
    r.training_records = static_cast<std::size_t>(s.get_int(6));
    r.held_out_records = static_cast<std::size_t>(s.get_int(7));
    r.k_wear_before = optional_double(s, 8);
    r.k_wear_after = optional_double(s, 9);
    if (!s.is_null(10)) plot_from(s.get_text(10), r, g.id);
    out.push_back(std::move(g));
  }
  return out;
}

// Fills a loaded run's families, candidates and chosen effects; positions put each list back in
// the diagnosis's order.
class GapReportDetails {
 public:
  explicit GapReportDetails(Database& db)
      : families_(db, "SELECT family, before_position, before_resolved, before_unresolved_reason, before_distance_db,"
                      " before_interval_low_db, before_interval_high_db, before_energy_share, before_significant,"
                      " after_position, after_resolved, after_unresolved_reason, after_distance_db, after_interval_low_db,"
                      " after_interval_high_db, after_energy_share, after_significant, unexplained_position"
                      " FROM gap_report_families WHERE report_id = ?"),
        candidates_(db, "SELECT rank, effect, shrinkage, information_criterion, worsens_other_family, parameters"
                        " FROM gap_report_candidates WHERE report_id = ? ORDER BY rank"),
        candidate_families_(db, "SELECT family, explains_position, held_out_position, resolved, unresolved_reason, distance_db,"
                                " interval_low_db, interval_high_db, energy_share, significant"
                                " FROM gap_candidate_families WHERE report_id = ? AND rank = ?"),
        chosen_(db, "SELECT effect FROM gap_report_chosen WHERE report_id = ? ORDER BY step") {}

  void fill(StoredGapReport& g) {
    read_families(g);
    read_candidates(g);
    read_chosen(g);
  }

 private:
  void read_families(StoredGapReport& g) {
    gap::GapReport& r = g.report;
    std::map<std::int64_t, gap::FamilyGap> before, after;
    std::map<std::int64_t, gap::FamilyKind> unexplained;
    families_.bind(1, g.id);
    while (families_.step()) {
      const gap::FamilyKind kind = family_of(families_.get_text(0), g.id);
      if (!families_.is_null(1)) before[families_.get_int(1)] = read_gap(families_, 2, kind);
      if (!families_.is_null(9)) after[families_.get_int(9)] = read_gap(families_, 10, kind);
      if (!families_.is_null(17)) unexplained[families_.get_int(17)] = kind;
    }
    families_.reset();
    for (auto& [pos, gap_value] : before) r.before.push_back(gap_value);
    for (auto& [pos, gap_value] : after) r.after.push_back(gap_value);
    for (auto& [pos, kind] : unexplained) r.unexplained.push_back(kind);
  }

  void read_candidates(StoredGapReport& g) {
    candidates_.bind(1, g.id);
    while (candidates_.step()) {
      gap::CandidateScore c;
      const std::int64_t rank = candidates_.get_int(0);
      c.effect = effect_of(candidates_.get_text(1), g.id);
      c.shrinkage = double_or_nan(candidates_, 2);
      c.information_criterion = double_or_nan(candidates_, 3);
      c.worsens_other_family = candidates_.get_int(4) != 0;
      parameters_from(candidates_.get_text(5), g.id, c);
      read_candidate_families(g.id, rank, c);
      g.report.candidates.push_back(std::move(c));
    }
    candidates_.reset();
  }

  void read_candidate_families(std::int64_t report_id, std::int64_t rank, gap::CandidateScore& c) {
    std::map<std::int64_t, gap::FamilyKind> explains;
    std::map<std::int64_t, gap::FamilyGap> held_out;
    candidate_families_.bind(1, report_id).bind(2, rank);
    while (candidate_families_.step()) {
      const gap::FamilyKind kind = family_of(candidate_families_.get_text(0), report_id);
      if (!candidate_families_.is_null(1)) explains[candidate_families_.get_int(1)] = kind;
      if (!candidate_families_.is_null(2)) held_out[candidate_families_.get_int(2)] = read_gap(candidate_families_, 3, kind);
    }
    candidate_families_.reset();
    for (auto& [pos, kind] : explains) c.explains.push_back(kind);
    for (auto& [pos, gap_value] : held_out) c.held_out_after.push_back(gap_value);
  }

  void read_chosen(StoredGapReport& g) {
    chosen_.bind(1, g.id);
    while (chosen_.step()) g.report.chosen.push_back(effect_of(chosen_.get_text(0), g.id));
    chosen_.reset();
  }

  Statement families_, candidates_, candidate_families_, chosen_;
};

}  // namespace

std::vector<StoredGapReport> load_gap_reports(Database& db, std::optional<std::size_t> newest) {
  if (!has_gap_report_tables(db)) return {};
  std::vector<StoredGapReport> out = load_gap_report_runs(db, newest);
  GapReportDetails details(db);
  for (StoredGapReport& g : out) details.fill(g);
  return out;
}

}  // namespace gearwatch::storage
