# stemmap_library(NAME SOURCES ... DEPS ...): one library per module folder.
function(stemmap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(stemmap_${name} STATIC ${ARG_SOURCES})
  target_include_directories(stemmap_${name} PUBLIC ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(stemmap_${name} PUBLIC ${ARG_DEPS})
endfunction()

# Tests write their scratch files under the build folder (TMPDIR, which std::filesystem's
# temp_directory_path() and GoogleTest's TempDir() follow), not into the system's /tmp: a run
# leaves nothing behind outside it, and two build folders never share a file (but for the
# simulated captures named by STEMMAP_TEST_RENDERS, where it is set: src/stemmap/cli/test_renders.h).
set(STEMMAP_TEST_TMPDIR "${CMAKE_BINARY_DIR}/test_tmp")
file(MAKE_DIRECTORY "${STEMMAP_TEST_TMPDIR}")

# stemmap_test(NAME SOURCES ... DEPS ...): a GoogleTest binary found by ctest.
function(stemmap_test name)
  if(NOT STEMMAP_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  # An empty value would drop out of the list and pair the next property's name with nothing.
  set(properties ENVIRONMENT "TMPDIR=${STEMMAP_TEST_TMPDIR}")
  if(ARG_LABELS)
    list(APPEND properties LABELS "${ARG_LABELS}")
  endif()
  # End-to-end tests take minutes under the sanitizers: started first, the unit tests fill the
  # other core beside them instead of leaving it idle at the end.
  if("e2e" IN_LIST ARG_LABELS)
    list(APPEND properties COST 1000)
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${properties})
endfunction()
