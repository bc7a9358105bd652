#include "gap_print.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "cli_common.hpp"

namespace gearwatch::cli {
namespace {

using nlohmann::json;

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json numbers(const std::vector<double>& values) {
  json a = json::array();
  for (double v : values) a.push_back(number(v));
  return a;
}
json optional_number(const std::optional<double>& v) { return v ? number(*v) : json(nullptr); }

json family_json(const gap::FamilyGap& g) {
  return {{"family", gap::to_string(g.family)},
          {"resolved", g.resolved},
          {"unresolved_reason", g.resolved ? json(nullptr) : json(g.unresolved_reason)},
          {"distance_db", number(g.distance_db)},
          {"interval_db", {number(g.distance_interval_db.low), number(g.distance_interval_db.high)}},
          {"energy_share", number(g.energy_share)},
          {"significant", g.significant}};
}

json families_json(const std::vector<gap::FamilyGap>& list) {
  json a = json::array();
  for (const auto& g : list) a.push_back(family_json(g));
  return a;
}

template <class List>
json tokens(const List& list) {
  json a = json::array();
  for (auto v : list) a.push_back(gap::to_string(v));
  return a;
}

json candidate_json(const gap::CandidateScore& c, std::size_t rank) {
  json parameters = json::array();
  for (const auto& [name, value] : c.parameters) parameters.push_back({name, number(value)});
  return {{"rank", rank},
          {"effect", gap::to_string(c.effect)},
          {"parameters", parameters},
          {"explains", tokens(c.explains)},
          {"shrinkage", number(c.shrinkage)},
          {"information_criterion", number(c.information_criterion)},
          {"worsens_other_family", c.worsens_other_family},
          {"held_out_after", families_json(c.held_out_after)}};
}

json bands_json(const std::vector<std::pair<gap::FamilyKind, gap::Interval>>& list) {
  json a = json::array();
  for (const auto& [family, interval] : list) a.push_back({gap::to_string(family), number(interval.low), number(interval.high)});
  return a;
}

json plot_json(const gap::GapReport& r) {
  return {{"order_axis", numbers(r.order_axis)},       {"measured_order_db", numbers(r.measured_order_db)},
          {"twin_order_db", numbers(r.twin_order_db)}, {"twin_after_order_db", numbers(r.twin_after_order_db)},
          {"hz_axis", numbers(r.hz_axis)},             {"measured_hz_db", numbers(r.measured_hz_db)},
          {"twin_hz_db", numbers(r.twin_hz_db)},       {"twin_after_hz_db", numbers(r.twin_after_hz_db)},
          {"order_bands", bands_json(r.order_bands)},  {"hz_bands", bands_json(r.hz_bands)}};
}

std::string fixed(double v, const char* format = "%.3f") {
  if (!std::isfinite(v)) return "-";
  char b[48];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

std::string pad(std::string text, std::size_t width) {
  if (text.size() < width) text += std::string(width - text.size(), ' ');
  return text;
}

std::string family_cell(const gap::FamilyGap& g) {
  if (!g.resolved) return "unresolved";
  return fixed(g.distance_db, "%.2f") + " [" + fixed(g.distance_interval_db.low, "%.2f") + ", " +
         fixed(g.distance_interval_db.high, "%.2f") + "]" + (g.significant ? " *" : "");
}

std::string list_text(const json& tokens_json) {
  std::string out;
  for (const auto& t : tokens_json) out += (out.empty() ? "" : ", ") + t.get<std::string>();
  return out.empty() ? "none" : out;
}

void print_families(std::ostream& out, const gap::GapReport& r) {
  out << pad("family", 21) << pad("twin alone (dB, 90 % interval)", 34) << pad("with the chosen effects", 34) << "reason\n";
  for (std::size_t i = 0; i < r.before.size(); ++i) {
    const auto& b = r.before[i];
    const std::string after = i < r.after.size() ? family_cell(r.after[i]) : "-";
    out << pad(gap::to_string(b.family), 21) << pad(family_cell(b), 34) << pad(after, 34) << (b.resolved ? "" : b.unresolved_reason)
        << "\n";
  }
  out << "(* significant)\n";
}

void print_candidates(std::ostream& out, const gap::GapReport& r) {
  if (r.candidates.empty()) {
    out << "candidates: none scored (no family significant, or localisation only)\n";
    return;
  }
  out << pad("rank", 6) << pad("effect", 19) << pad("shrinkage", 11) << pad("IC", 11) << pad("worsens", 9) << "parameters\n";
  for (std::size_t i = 0; i < r.candidates.size(); ++i) {
    const auto& c = r.candidates[i];
    // A per-harmonic form has hundreds of values: the table shows the first few, the JSON all.
    constexpr std::size_t kShown = 6;
    std::string parameters;
    for (std::size_t k = 0; k < c.parameters.size() && k < kShown; ++k)
      parameters += (parameters.empty() ? "" : ", ") + c.parameters[k].first + " " + fixed(c.parameters[k].second, "%.4g");
    if (c.parameters.size() > kShown) parameters += ", ... (" + std::to_string(c.parameters.size() - kShown) + " more in --format json)";
    out << pad(std::to_string(i + 1), 6) << pad(gap::to_string(c.effect), 19) << pad(fixed(c.shrinkage), 11)
        << pad(fixed(c.information_criterion), 11) << pad(c.worsens_other_family ? "yes" : "no", 9) << parameters << "\n";
  }
}


json described_json(const gap::FeatureDescription& d) {
  json parameters = json::array();
  for (const auto& [name, value] : d.parameters) parameters.push_back({name, number(value)});
  return {{"kind", gap::to_string(d.kind)}, {"shaft", gap::to_string(d.shaft)}, {"parameters", parameters},
          {"gap_db", number(d.gap_db)}, {"residual_db", number(d.residual_db)}, {"text", gap::describe(d)}};
}


/// The report's features, largest first, with their descriptions, and the candidates fitted at a
/// bound of their range with what they would need.
json features_json(const gap::GapReport& r) {
  json features = json::array(), bounds = json::array();
  for (const auto& f : r.features) {
    json seen = json::array();
    for (const auto& w : f.seen_in)
      seen.push_back({{"set", w.held_out ? "held_out" : "training"}, {"record", w.record}, {"speed_hz", number(w.speed_hz)},
                      {"torque_nm", number(w.torque_nm)}, {"order", number(w.order)}, {"hz", number(w.hz)},
                      {"size_db", number(w.size_db)}});
    features.push_back({{"movement", gap::to_string(f.movement)}, {"shaft", gap::to_string(f.shaft)}, {"order", number(f.order)},
                        {"order_low", number(f.order_low)}, {"order_high", number(f.order_high)}, {"hz", number(f.hz)},
                        {"hz_low", number(f.hz_low)}, {"hz_high", number(f.hz_high)}, {"size_db", number(f.size_db)},
                        {"size_interval_db", {number(f.size_interval_db.low), number(f.size_interval_db.high)}},
                        {"p_value", number(f.p_value)}, {"description", gap::describe(f)}, {"seen_in", seen},
                        {"described_as", described_json(f.description)}, {"explained_by", f.explained_by ? json(gap::to_string(*f.explained_by)) : json(nullptr)},
                        {"statement", gap::statement(f)}});
  }
  for (const auto& c : r.candidates)
    for (const auto& b : c.at_bounds) {
      const auto reading = gap::reading_of(b);
      bounds.push_back({{"effect", gap::to_string(c.effect)}, {"parameter", b.name}, {"bound", number(b.bound)},
                        {"side", b.upper ? "upper" : "lower"}, {"value", number(reading.value)}, {"unit", reading.unit},
                        {"quantity", reading.quantity}, {"description", gap::describe(c.effect, b)}});
    }
  return {{"features", features}, {"at_bounds", bounds}};
}

void print_features(std::ostream& out, const gap::GapReport& r) {
  out << "features (" << r.features.size() << "):\n";
  if (r.features.empty()) out << "  none: no line or band off the twin beyond its noise and the practical minimum\n";
  char line[256];
  std::snprintf(line, sizeof line, "  %-16s %-7s %10s %10s %-21s %8s %-17s %s\n", "movement", "shaft", "order", "Hz", "band Hz",
                "size dB", "interval dB", "records");
  if (!r.features.empty()) out << line;
  for (const auto& f : r.features) {
    std::snprintf(line, sizeof line, "  %-16s %-7s %10.2f %10.1f %9.1f-%-11.1f %+8.2f [%+6.2f, %+6.2f] %zu\n", gap::to_string(f.movement),
                  gap::to_string(f.shaft), f.order, f.hz, f.hz_low, f.hz_high, f.size_db, f.size_interval_db.low,
                  f.size_interval_db.high, f.seen_in.size());
    out << line;
  }
  for (std::size_t i = 0; i < r.features.size(); ++i) out << "  feature " << i + 1 << ": " << gap::statement(r.features[i]) << "\n";
  for (const auto& c : r.candidates)
    for (const auto& b : c.at_bounds) out << "fitted at a bound: " << gap::describe(c.effect, b) << "\n";
}

}  // namespace

json gap_report_json(const storage::StoredGapReport& s, bool stored) {
  const gap::GapReport& r = s.report;
  json candidates = json::array();
  for (std::size_t i = 0; i < r.candidates.size(); ++i) candidates.push_back(candidate_json(r.candidates[i], i + 1));
  const json features = features_json(r);
  return {{"id", stored ? json(s.id) : json(nullptr)},
          {"created_at", stored ? json(s.created_at) : json(nullptr)},
          {"record_id", stored && s.context.record_id ? json(*s.context.record_id) : json(nullptr)},
          {"gear_pair", s.context.gear_pair},
          {"input_revolutions", number(r.input_revolutions)},
          {"speeds_hz", numbers(r.speeds_hz)},
          {"training_records", r.training_records},
          {"held_out_records", r.held_out_records},
          {"before", families_json(r.before)},
          {"candidates", candidates},
          {"chosen", tokens(r.chosen)},
          {"after", families_json(r.after)},
          {"unexplained", tokens(r.unexplained)},
          {"k_wear_before", optional_number(r.k_wear_before)},
          {"k_wear_after", optional_number(r.k_wear_after)},
          {"plot", plot_json(r)},
          {"features", features["features"]},
          {"at_bounds", features["at_bounds"]}};
}

void print_gap_report_table(std::ostream& out, const storage::StoredGapReport& s, bool stored) {
  const gap::GapReport& r = s.report;
  std::string speeds;
  for (double v : r.speeds_hz) speeds += (speeds.empty() ? "" : ", ") + fixed(v, "%.4g");
  out << "gap report " << (stored ? "#" + std::to_string(s.id) + " (" + s.created_at + ")" : std::string("(not stored)"))
      << ", gear pair " << s.context.gear_pair << ", at " << fixed(r.input_revolutions, "%.6g") << " cycles\n";
  out << "records: " << r.training_records << " training, " << r.held_out_records << " held out; speeds " << speeds << " Hz\n";
  print_families(out, r);
  print_candidates(out, r);
  out << "chosen: " << list_text(tokens(r.chosen)) << "\n";
  out << "unexplained: " << list_text(tokens(r.unexplained)) << "\n";
  if (r.k_wear_before && r.k_wear_after)
    out << "K_wear: " << fixed(*r.k_wear_before, "%.4g") << " m^2/N with the twin alone, " << fixed(*r.k_wear_after, "%.4g")
        << " m^2/N with the chosen effects\n";
  else
    out << "K_wear: not inferred\n";
  print_features(out, r);
}

void print_gap_report(const storage::StoredGapReport& report, const std::string& format, bool stored) {
  if (format == "json") std::cout << dump_json(gap_report_json(report, stored)) << "\n";
  else print_gap_report_table(std::cout, report, stored);
}

}  // namespace gearwatch::cli
