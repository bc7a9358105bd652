#include "utc_time.hpp"

#include <chrono>
#include <cstdio>
#include <regex>

#include "commands.hpp"

namespace gearwatch::cli {

namespace {

int field(const std::ssub_match& m, int absent = 0) { return m.matched ? std::stoi(m.str()) : absent; }

int milliseconds(const std::ssub_match& m) {
  if (!m.matched) return 0;
  std::string digits = m.str();
  digits.resize(3, '0');  // ".25" is 250 ms
  return std::stoi(digits);
}

}  // namespace

std::string parse_utc_time(const std::string& text, const std::string& option) {
  static const std::regex form(R"((\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2})(?:\.(\d{1,3}))?)?Z?)?)");
  std::smatch m;
  const auto refuse = [&](const std::string& why) {
    return CommandError(option + " " + text + ": " + why + "; accepted forms: " + kAcceptedTimeForms);
  };
  if (!std::regex_match(text, m, form)) throw refuse("not a time");
  const std::chrono::year_month_day date{std::chrono::year{field(m[1])}, std::chrono::month{static_cast<unsigned>(field(m[2]))},
                                         std::chrono::day{static_cast<unsigned>(field(m[3]))}};
  if (!date.ok()) throw refuse("no such date");
  const int hour = field(m[4]), minute = field(m[5]), second = field(m[6]);
  if (hour > 23 || minute > 59 || second > 59) throw refuse("no such time of day");
  char out[64];  // room for any int the compiler cannot rule out (the fields are checked above)
  std::snprintf(out, sizeof out, "%s-%s-%sT%02d:%02d:%02d.%03dZ", m[1].str().c_str(), m[2].str().c_str(), m[3].str().c_str(), hour,
                minute, second, milliseconds(m[7]));
  return out;
}

}  // namespace gearwatch::cli
