# stemmap_library(NAME SOURCES ... DEPS ...): one library per module folder.
function(stemmap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(stemmap_${name} STATIC ${ARG_SOURCES})
  target_include_directories(stemmap_${name} PUBLIC ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(stemmap_${name} PUBLIC ${ARG_DEPS})
endfunction()

# stemmap_test(NAME SOURCES ... DEPS ...): a GoogleTest binary found by ctest.
function(stemmap_test name)
  if(NOT STEMMAP_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS "${ARG_LABELS}")
endfunction()
