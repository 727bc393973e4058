// A test that cannot run (../shared absent) calls PRISM_TEST_SKIP: Catch2 v2
// has no SKIP, so it prints a warning starting with "SKIPPED: " and returns;
// ctest reports the test skipped (SKIP_REGULAR_EXPRESSION in tests/CMakeLists.txt).
// With PRISM_REQUIRE_SHARED=1 in the environment (scripts/test.sh sets it
// whenever ../shared exists) the test fails instead, naming what is missing:
// a run with ../shared beside it cannot pass by skipping.
#pragma once
#include <catch2/catch.hpp>
#include <cstdlib>
#include <cstring>

namespace prism_test {
inline bool shared_required() {
  const char* v = std::getenv("PRISM_REQUIRE_SHARED");
  return v && std::strcmp(v, "1") == 0;
}
}  // namespace prism_test

// Fails the test when ../shared is required; a test that runs on without
// what is missing (only part of it needs ../shared) calls this alone.
// (The message must not contain the skip marker: ctest would report the
// failed test as skipped.)
#define PRISM_TEST_FAIL_IF_SHARED_REQUIRED(msg)                                    \
  do {                                                                             \
    if (prism_test::shared_required())                                             \
      FAIL("missing though PRISM_REQUIRE_SHARED=1 (../shared is present): " << msg); \
  } while (0)

#define PRISM_TEST_SKIP(msg)                  \
  do {                                        \
    PRISM_TEST_FAIL_IF_SHARED_REQUIRED(msg);  \
    WARN("SKIPPED: " << msg);                 \
    return;                                   \
  } while (0)
