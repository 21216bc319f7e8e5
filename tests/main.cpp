// doctest entry point for the whole suite; every TEST_CASE is registered with ctest by
// doctest_discover_tests. Tests mirror the source tree (tests/systems, tests/engine/...).
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>
