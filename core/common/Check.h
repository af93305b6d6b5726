#pragma once
// Always-on checks for programming errors (bugs), printing both operands. Not for user input:
// bad input throws ps::Error (see Error.h).
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace ps::detail {
[[noreturn]] inline void checkFailed(const char* file, int line, const std::string& what) {
  std::fprintf(stderr, "%s:%d: check failed: %s\n", file, line, what.c_str());
  std::abort();
}
template <typename A, typename B>
std::string describe(const char* expr, const A& a, const B& b) {
  std::ostringstream s;
  s << expr << " (" << a << " vs " << b << ")";
  return s.str();
}
}  // namespace ps::detail

#define PS_CHECK(cond) ((cond) ? (void)0 : ::ps::detail::checkFailed(__FILE__, __LINE__, #cond))
#define PS_CHECK_OP(a, op, b)                                                           \
  do {                                                                                  \
    const auto& psA_ = (a);                                                             \
    const auto& psB_ = (b);                                                             \
    if (!(psA_ op psB_))                                                                \
      ::ps::detail::checkFailed(__FILE__, __LINE__,                                     \
                                ::ps::detail::describe(#a " " #op " " #b, psA_, psB_)); \
  } while (0)
#define PS_CHECK_EQ(a, b) PS_CHECK_OP(a, ==, b)
#define PS_CHECK_LT(a, b) PS_CHECK_OP(a, <, b)
#define PS_CHECK_LE(a, b) PS_CHECK_OP(a, <=, b)
#define PS_CHECK_GE(a, b) PS_CHECK_OP(a, >=, b)
