#pragma once
// The one reader of an enum's tokens (configuration values, stored tokens, command-line words):
// the value whose to_string is the token, so each enum's to_string stays its only spelling.
#include <array>
#include <cstddef>
#include <optional>
#include <string_view>

namespace gearwatch {

/// The value of `all` whose to_string (found by argument lookup) is `token`, or nullopt.
template <typename Enum, std::size_t N>
constexpr std::optional<Enum> from_token(const std::array<Enum, N>& all, std::string_view token) noexcept {
  for (Enum value : all)
    if (token == to_string(value)) return value;
  return std::nullopt;
}

}  // namespace gearwatch
