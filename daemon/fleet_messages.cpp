// The fleet consumer's reading of one message (docs/fleet.md): topic, UTF-8, JSON, schema.
#include "fleet_messages.hpp"

#include <algorithm>
#include <string>

#include "gearwatch/types/alerts.hpp"

#include <nlohmann/json.hpp>

namespace gearwatch::daemon {

namespace {

using nlohmann::json;

// A payload that does not follow its topic's schema: the reason names the field.
struct SchemaError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const json& field(const json& j, const char* name) {
  if (!j.is_object()) throw SchemaError("expected a JSON object");
  const auto it = j.find(name);
  if (it == j.end()) throw SchemaError(std::string("missing required field '") + name + "'");
  return *it;
}
// The field `name` when `is_kind` holds for it; else "'name' must be <what>".
const json& checked(const json& j, const char* name, bool (json::*is_kind)() const noexcept, const char* what) {
  const json& v = field(j, name);
  if (!(v.*is_kind)()) throw SchemaError(std::string("'") + name + "' must be " + what);
  return v;
}
std::string text(const json& j, const char* name) { return checked(j, name, &json::is_string, "a string").get<std::string>(); }
std::int64_t whole(const json& j, const char* name) {
  return checked(j, name, &json::is_number_integer, "an integer").get<std::int64_t>();
}
std::optional<std::int64_t> whole_or_null(const json& j, const char* name) {
  if (field(j, name).is_null()) return std::nullopt;
  return whole(j, name);
}
bool flag(const json& j, const char* name) { return checked(j, name, &json::is_boolean, "a boolean").get<bool>(); }
std::optional<double> number_or_null(const json& j, const char* name) {
  if (field(j, name).is_null()) return std::nullopt;
  return checked(j, name, &json::is_number, "a number or null").get<double>();
}
const json& array(const json& j, const char* name) { return checked(j, name, &json::is_array, "an array"); }
const json& object(const json& j, const char* name) { return checked(j, name, &json::is_object, "an object"); }
int channel_number(const json& j) {
  const std::int64_t c = whole(j, "channel");
  if (c < 0 || c > 255) throw SchemaError("'channel' out of range 0..255");
  return static_cast<int>(c);
}

fleet::MessageHeader header(const json& j) {
  fleet::MessageHeader h;
  h.site = text(j, "site");
  h.gearbox = text(j, "gearbox");
  h.message_id = whole(j, "message_id");
  h.record_id = whole_or_null(j, "record_id");
  h.record_time = text(j, "record_time");
  (void)text(j, "topic");
  return h;
}

fleet::RecordMessage record_message(const json& j) {
  fleet::RecordMessage m;
  m.header = header(j);
  if (!m.header.record_id) throw SchemaError("'record_id' must not be null on a record");
  m.stream_sequence = whole(j, "stream_sequence");
  m.start_index = whole(j, "start_index");
  m.duration_s = number_or_null(j, "duration_s");
  m.analysed = flag(j, "analysed");
  m.reject_reason = text(j, "reject_reason");
  m.speed_hz = number_or_null(j, "speed_hz");
  m.torque_nm = number_or_null(j, "torque_nm");
  m.input_revolutions = number_or_null(j, "input_revolutions");
  for (const json& ch : array(j, "channels")) {
    const int c = channel_number(ch);
    const json& values = object(ch, "indicators");
    for (const auto& [name, value] : values.items()) {
      if (!value.is_null() && !value.is_number()) throw SchemaError("indicator '" + name + "' must be a number or null");
      m.indicators.push_back({c, name, value.is_null() ? std::nullopt : std::optional<double>(value.get<double>())});
    }
    for (const json& k : array(ch, "skipped")) m.skipped.push_back({c, text(k, "indicator"), text(k, "reason"), text(k, "detail")});
  }
  return m;
}

fleet::WearMessage wear_message(const json& j) {
  fleet::WearMessage m;
  m.header = header(j);
  for (const json& v : array(j, "verdicts"))
    m.verdicts.push_back({channel_number(v), text(v, "mechanism"), whole(v, "points"), number_or_null(v, "low_band_p"),
                          number_or_null(v, "high_band_p"), text(v, "evidence")});
  return m;
}

// One of the daemon's severities, by the enum's own names (kAllAlertSeverities).
bool is_alert_severity(const std::string& s) {
  return std::any_of(kAllAlertSeverities.begin(), kAllAlertSeverities.end(), [&](AlertSeverity v) { return s == to_string(v); });
}

fleet::AlertMessage alert_message(const json& j) {
  fleet::AlertMessage m;
  m.header = header(j);
  const auto transition = fleet::parse_alert_transition(text(j, "transition"));
  if (!transition) throw SchemaError("'transition' must be raised, cleared or event");
  m.transition = *transition;
  m.severity = text(j, "severity");
  if (!is_alert_severity(m.severity)) throw SchemaError("'severity' must be info, warning or alarm");
  m.kind = text(j, "kind");
  if (!field(j, "channel").is_null()) m.channel = channel_number(j);
  m.subject = text(j, "subject");
  m.value = text(j, "value");
  m.message = text(j, "message");
  return m;
}

fleet::ModelMessage model_message(const json& j) {
  fleet::ModelMessage m;
  m.header = header(j);
  m.model_run_id = whole(j, "model_run_id");
  m.gear_pair = whole(j, "gear_pair");
  m.advanced = flag(j, "advanced");
  m.cycles = number_or_null(j, "cycles");
  m.k_wear = number_or_null(j, "k_wear");
  m.k_pitting = number_or_null(j, "k_pitting");
  m.wear_mean_depth_m = number_or_null(j, "wear_mean_depth_m");
  m.wear_max_depth_m = number_or_null(j, "wear_max_depth_m");
  m.pitting_mean = number_or_null(j, "pitting_mean");
  const json& forecast = object(j, "forecast");
  m.forecast_json = forecast.dump();
  return m;
}

fleet::GapMessage gap_message(const json& j) {
  fleet::GapMessage m;
  m.header = header(j);
  m.gap_report_id = whole(j, "gap_report_id");
  m.gear_pair = whole(j, "gear_pair");
  m.input_revolutions = number_or_null(j, "input_revolutions");
  m.significant_families_json = array(j, "significant_families").dump();
  m.chosen_effects_json = array(j, "chosen_effects").dump();
  m.unexplained_families_json = array(j, "unexplained_families").dump();
  return m;
}

bool identifier(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

fleet::HealthMessage health_message(const json& j) {
  fleet::HealthMessage m;
  m.header = header(j);
  m.final = flag(j, "final");
  const json& counters = object(j, "counters");
  for (const auto& [name, value] : counters.items()) {
    if (!identifier(name)) throw SchemaError("counter name '" + name + "' is not an identifier");
    if (!value.is_number_integer()) throw SchemaError("counter '" + name + "' must be an integer");
    m.counters[name] = value.get<std::int64_t>();
  }
  return m;
}

fleet::StatusMessage status_message(const json& j) {
  fleet::StatusMessage m{text(j, "site"), text(j, "gearbox"), text(j, "state"), text(j, "version"), whole(j, "schema"), std::nullopt};
  if (m.state != "online" && m.state != "offline") throw SchemaError("'state' must be online or offline");
  if (j.contains("delivered_through")) m.delivered_through = whole(j, "delivered_through");
  return m;
}

fleet::GoneMessage gone_message(const json& j) {
  fleet::GoneMessage m{text(j, "site"), text(j, "gearbox"), {}};
  for (const auto& r : array(j, "ranges")) {
    const auto reason = fleet::parse_gone_reason(text(r, "reason"));
    if (!reason) throw SchemaError("'reason' must be not_held or refused");
    fleet::LostRange range{whole(r, "from"), whole(r, "to"), *reason};
    if (range.from < 1 || range.from > range.to) throw SchemaError("a range must have 1 <= from <= to");
    m.ranges.push_back(range);
  }
  return m;
}

FleetMessage typed_message(const std::string& kind, const json& j) {
  if (kind == "record") return record_message(j);
  if (kind == "wear") return wear_message(j);
  if (kind == "alert") return alert_message(j);
  if (kind == "model") return model_message(j);
  if (kind == "gap") return gap_message(j);
  if (kind == "health") return health_message(j);
  if (kind == "resend_gone") return gone_message(j);
  return status_message(j);
}

bool known_kind(const std::string& kind) {
  for (const char* k : {"record", "wear", "alert", "model", "gap", "health", "status", "resend_gone"})
    if (kind == k) return true;
  return false;
}

// <prefix>/<site>/<gearbox>/<kind>: the three levels after the prefix, or nothing.
struct TopicLevels {
  std::string site, gearbox, kind;
};
std::optional<TopicLevels> topic_levels(const std::string& prefix, const std::string& topic) {
  if (topic.size() <= prefix.size() + 1 || topic.compare(0, prefix.size(), prefix) != 0 || topic[prefix.size()] != '/')
    return std::nullopt;
  const std::string rest = topic.substr(prefix.size() + 1);
  const auto a = rest.find('/');
  const auto b = a == std::string::npos ? a : rest.find('/', a + 1);
  if (b == std::string::npos || rest.find('/', b + 1) != std::string::npos) return std::nullopt;
  return TopicLevels{rest.substr(0, a), rest.substr(a + 1, b - a - 1), rest.substr(b + 1)};
}

// The payload speaks for the gearbox of its topic, and for that topic.
void check_payload_matches_topic(const json& j, const TopicLevels& t) {
  if (text(j, "site") != t.site || text(j, "gearbox") != t.gearbox)
    throw SchemaError("the payload names " + text(j, "site") + "/" + text(j, "gearbox") + " on the topic of " + t.site + "/" + t.gearbox);
  if (t.kind != "status" && t.kind != "resend_gone" && text(j, "topic") != t.kind) throw SchemaError("the payload's 'topic' is '" + text(j, "topic") + "' on a " + t.kind + " topic");
}

}  // namespace

bool is_utf8(const std::string& s) noexcept {
  std::size_t i = 0;
  const std::size_t n = s.size();
  while (i < n) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t len = 0;
    std::uint32_t cp = 0;
    if (c < 0x80) len = 1, cp = c;
    else if ((c & 0xE0) == 0xC0) len = 2, cp = c & 0x1F;
    else if ((c & 0xF0) == 0xE0) len = 3, cp = c & 0x0F;
    else if ((c & 0xF8) == 0xF0) len = 4, cp = c & 0x07;
    else return false;
    if (i + len > n) return false;
    for (std::size_t k = 1; k < len; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    static constexpr std::uint32_t kSmallest[] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < kSmallest[len] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += len;
  }
  return true;
}

std::string utf8_or_replaced(const std::string& s) {
  if (is_utf8(s)) return s;
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    // The longest well-formed sequence starting here (1..4 bytes), else one byte replaced.
    std::size_t len = 0;
    for (std::size_t l = 1; l <= 4 && i + l <= s.size(); ++l)
      if (is_utf8(s.substr(i, l))) {
        len = l;
        break;
      }
    if (len == 0) {
      out += '?';
      ++i;
    } else {
      out += s.substr(i, len);
      i += len;
    }
  }
  return out;
}

bool is_resend_request(const FleetAcceptance& accept, const std::string& topic) {
  const auto levels = topic_levels(accept.prefix, topic);
  return levels && levels->kind == "resend";
}

std::variant<FleetMessage, FleetRejection> parse_fleet_message(const FleetAcceptance& accept, const std::string& topic,
                                                               const std::string& payload) {
  const auto levels = topic_levels(accept.prefix, topic);
  if (!levels || !known_kind(levels->kind))
    return FleetRejection{fleet::RejectReason::unknown_topic,
                          "not <prefix>/<site>/<gearbox>/<record|wear|alert|model|gap|health|status|resend_gone>"};
  if (!accept.gearboxes.empty() && accept.gearboxes.count(levels->site + "/" + levels->gearbox) == 0)
    return FleetRejection{fleet::RejectReason::unknown_gearbox, "gearbox " + levels->site + "/" + levels->gearbox + " is not in --gearbox"};
  if (!is_utf8(payload)) return FleetRejection{fleet::RejectReason::not_utf8, "the payload is not UTF-8"};
  json j;
  try {
    j = json::parse(payload);
  } catch (const json::parse_error& e) {
    return FleetRejection{fleet::RejectReason::malformed_json, e.what()};
  }
  try {
    check_payload_matches_topic(j, *levels);
    return typed_message(levels->kind, j);
  } catch (const SchemaError& e) {
    return FleetRejection{fleet::RejectReason::wrong_schema, levels->kind + ": " + e.what()};
  }
}

}  // namespace gearwatch::daemon
