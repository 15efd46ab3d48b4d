# One module = one folder = one static library target, with its tests and microbenchmarks beside it.
#
#   linesight_add_module(core
#     SOURCES   error.cc progress.cc          # library sources
#     DEPS      OpenCV::core fmt::fmt         # public link dependencies
#     TESTS     error_test.cc                 # -> one gtest executable linesight_core_test
#     BENCHMARKS progress_benchmark.cc)       # -> one benchmark executable linesight_core_benchmark
include(GNUInstallDirs)

function(linesight_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wno-missing-field-initializers)
  if(LINESIGHT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

if(LINESIGHT_SANITIZE)
  # GCC 12's -Wmaybe-uninitialized gives false positives inside libstdc++ (std::regex, std::function) once the
  # sanitizers instrument the code; the Release build keeps the warning as an error.
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
                      -Wno-maybe-uninitialized)
  add_link_options(-fsanitize=address,undefined)
endif()

# Unity build (LINESIGHT_UNITY_BUILD): a target's sources compile in batches, so the heavy headers they share
# (OpenCV, Eigen, Ceres, CLI11, GoogleTest) are parsed and their inline code generated once per batch instead of
# once per file; a cold build takes about half the CPU time. Highway's foreach_target files re-include
# themselves once per instruction set and always compile on their own.
function(linesight_unity_build target)
  if(NOT LINESIGHT_UNITY_BUILD)
    return()
  endif()
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${LINESIGHT_UNITY_BATCH})
  get_target_property(sources ${target} SOURCES)
  foreach(src ${sources})
    if(src MATCHES "\\.cc$")
      cmake_path(ABSOLUTE_PATH src BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} OUTPUT_VARIABLE path)
      file(STRINGS ${path} hwy_dispatch REGEX "HWY_TARGET_INCLUDE" LIMIT_COUNT 1)
      if(hwy_dispatch)
        set_source_files_properties(${src} TARGET_DIRECTORY ${target} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
      endif()
    endif()
  endforeach()
endfunction()

# Registers a GoogleTest executable with CTest: each of its tests is one CTest test (`ctest -R` runs
# single tests). Under the sanitizers the executable runs once, as one CTest test, instead: a process
# start-up costs ~0.25 s there (ASan's set-up, 150 shared libraries), ~2 minutes over the suite;
# GTEST_FILTER in the environment then selects tests (scripts/test.sh).
function(linesight_add_gtest target label)
  if(LINESIGHT_SANITIZE)
    add_test(NAME ${target} COMMAND ${target})
    set_tests_properties(${target} PROPERTIES LABELS ${label})
  else()
    gtest_discover_tests(${target} DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 60 PROPERTIES LABELS ${label})
  endif()
endfunction()

function(linesight_add_module name)
  cmake_parse_arguments(M "" "" "SOURCES;DEPS;TESTS;TEST_DEPS;BENCHMARKS" ${ARGN})
  set(lib linesight_${name})
  add_library(${lib} STATIC ${M_SOURCES})
  add_library(linesight::${name} ALIAS ${lib})
  target_include_directories(${lib} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
                                           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${lib} PUBLIC ${M_DEPS})
  target_compile_features(${lib} PUBLIC cxx_std_20)  # the headers need C++20 (consumers of the package too)
  # The data folders of this build machine, for the tests and the CLI's defaults: never part of the
  # installed package's interface.
  target_compile_definitions(${lib} PUBLIC
    $<BUILD_INTERFACE:LINESIGHT_SHARED_DATA_DIR="${LINESIGHT_SHARED_DATA_DIR}">
    $<BUILD_INTERFACE:LINESIGHT_OPENCV_DATA_DIR="${LINESIGHT_OPENCV_DATA_DIR}">)
  # Installed (cmake/linesight_install.cmake) as linesight::${name} with the folder's public headers: not
  # the tests' helpers (*_test_util.h), the sources' own (*_internal.h) or the headers of test-only sources.
  file(GLOB headers CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  list(FILTER headers EXCLUDE REGEX "_(test_util|internal)\\.h$")
  foreach(src ${M_TESTS} ${M_BENCHMARKS})
    if(NOT src IN_LIST M_SOURCES)
      string(REGEX REPLACE "\\.cc$" ".h" header ${CMAKE_CURRENT_SOURCE_DIR}/${src})
      list(REMOVE_ITEM headers ${header})
    endif()
  endforeach()
  set_target_properties(${lib} PROPERTIES EXPORT_NAME ${name} PUBLIC_HEADER "${headers}")
  set_property(GLOBAL APPEND PROPERTY LINESIGHT_MODULES ${name})
  linesight_target_warnings(${lib})
  linesight_unity_build(${lib})

  if(LINESIGHT_BUILD_TESTS AND M_TESTS)
    add_executable(${lib}_test ${M_TESTS})
    # Tests may compare with imgcodecs or write videos: they link all of OpenCV.
    target_link_libraries(${lib}_test PRIVATE ${lib} ${M_TEST_DEPS} ${OpenCV_LIBS} GTest::gtest GTest::gmock
                                              GTest::gtest_main)
    linesight_target_warnings(${lib}_test)
    linesight_unity_build(${lib}_test)
    linesight_add_gtest(${lib}_test ${name})
  endif()
  if(LINESIGHT_BUILD_BENCHMARKS AND M_BENCHMARKS)
    add_executable(${lib}_benchmark ${M_BENCHMARKS})
    target_link_libraries(${lib}_benchmark PRIVATE ${lib} benchmark::benchmark benchmark::benchmark_main)
    linesight_target_warnings(${lib}_benchmark)
  endif()
endfunction()
