// libFuzzer target: the `candump -L` line parser (acquisition/candump_log). Every input line must
// either parse or come back with a reason (never both, never a crash); a line that parses must
// format back to a line that parses to the same frame, and formatting is a fixed point: the
// text of parse(format(frame)) formatted again is the same text.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "gearwatch/acquisition/candump_log.hpp"

namespace acq = gearwatch::acquisition;

namespace {

[[noreturn]] void violated(const char* what, std::string_view line) {
  std::fprintf(stderr, "fuzz_candump_log: invariant violated: %s\n  line: %.*s\n", what, static_cast<int>(line.size()),
               line.data());
  std::abort();
}

bool same_frame(const acq::CanFrame& a, const acq::CanFrame& b) {
  if (a.id != b.id || a.len != b.len || a.fd != b.fd || a.extended != b.extended || a.remote != b.remote ||
      a.error != b.error || (a.fd && a.fd_flags != b.fd_flags))
    return false;
  if (a.remote) return true;  // a remote frame carries a length, not data
  for (unsigned i = 0; i < a.len; ++i)
    if (a.data[i] != b.data[i]) return false;
  return true;
}

void check_line(std::string_view line) {
  std::string reason;
  const auto parsed = acq::parse_candump_line(line, reason);
  if (!parsed) return;
  if (!reason.empty()) violated("a parsed line with a reason", line);
  const acq::CanFrame& f = parsed->frame;
  if (f.fd ? !acq::is_valid_fd_length(f.len) : f.len > 8) violated("payload length out of range", line);
  if (f.id > (f.extended ? 0x1FFFFFFFu : 0x7FFu)) violated("identifier out of range", line);

  std::string text, again_text;
  acq::format_candump_line(f, parsed->interface, text);
  std::string again_reason;
  const auto again = acq::parse_candump_line(text, again_reason);
  if (!again) violated(("the formatted line does not parse: " + again_reason + ": " + text).c_str(), line);
  if (!same_frame(f, again->frame)) violated(("the formatted line is another frame: " + text).c_str(), line);
  if (again->interface != parsed->interface) violated("the formatted line has another interface", line);
  acq::format_candump_line(again->frame, again->interface, again_text);
  if (again_text != text) violated(("formatting is not a fixed point: " + text + " -> " + again_text).c_str(), line);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  // Each line on its own, as CandumpFileSource reads a log.
  std::size_t start = 0;
  while (start <= input.size()) {
    const std::size_t end = input.find('\n', start);
    check_line(input.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return 0;
}
