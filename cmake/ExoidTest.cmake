# exoid_add_test: the one way a test executable is declared (every folder's tests use it).
#
#   exoid_add_test(NAME SOURCES... [SANITIZED] [PROPERTIES ctest-properties...])
#
# Links GoogleTest's main, defines EXOID_CONFIG_DIR / EXOID_DATA_DIR / EXOID_BIN_DIR (the repository's config/ and
# data/, the build's bin/), and registers the executable's tests with ctest (gtest_discover_tests) with the given
# properties (a LABELS entry is expected: docs/testing.md lists the labels).
#
# Where CI runs it (scripts/test.sh; docs/testing.md "Which build runs which test"): every test runs once,
#   SANITIZED       in the sanitizer build only (AddressSanitizer + UndefinedBehaviorSanitizer, clang -O1): the
#                   readers, the messages, the model, the numerics' unit tests and the real-time code's, short
#                   under ASan;
#   (unmarked)      in the Release build only: the closed-loop, multi-process and command-line tests, and the
#                   numerics that take long under ASan.
# EXOID_TEST_SET chooses what a build directory builds and registers: all (the default: every test, for
# developers), sanitized (SANITIZED: the sanitizer build) or unsanitized (all but SANITIZED: CI's
# Release build). A test left out is EXCLUDE_FROM_ALL and unregistered; `exoid_sanitized` builds the sanitized set.
set(EXOID_TEST_SET "all" CACHE STRING "tests built and registered: all | sanitized | unsanitized (docs/testing.md)")
set_property(CACHE EXOID_TEST_SET PROPERTY STRINGS all sanitized unsanitized)
if(NOT EXOID_TEST_SET MATCHES "^(all|sanitized|unsanitized)$")
  message(FATAL_ERROR "EXOID_TEST_SET must be all, sanitized or unsanitized (got '${EXOID_TEST_SET}')")
endif()
add_custom_target(exoid_sanitized)
include(GoogleTest)

function(exoid_add_test name)
  cmake_parse_arguments(ARG "SANITIZED" "" "PROPERTIES" ${ARGN})
  set(in_set ON)
  if(EXOID_TEST_SET STREQUAL "sanitized" AND NOT ARG_SANITIZED)
    set(in_set OFF)
  elseif(EXOID_TEST_SET STREQUAL "unsanitized" AND ARG_SANITIZED)
    set(in_set OFF)
  endif()
  if(in_set)
    add_executable(${name} ${ARG_UNPARSED_ARGUMENTS})
  else()
    add_executable(${name} EXCLUDE_FROM_ALL ${ARG_UNPARSED_ARGUMENTS})
  endif()
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}
                                             ${CMAKE_CURRENT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE EXOID_CONFIG_DIR="${EXOID_CONFIG_DIR}"
                                             EXOID_DATA_DIR="${EXOID_DATA_DIR}"
                                             EXOID_BIN_DIR="${CMAKE_RUNTIME_OUTPUT_DIRECTORY}")
  target_link_libraries(${name} PRIVATE GTest::gtest_main)
  if(ARG_SANITIZED)
    add_dependencies(exoid_sanitized ${name})
  endif()
  if(in_set)
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${ARG_PROPERTIES})
  endif()
endfunction()
