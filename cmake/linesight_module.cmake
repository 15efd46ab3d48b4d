# One module = one folder = one static library target, with its tests and microbenchmarks beside it.
#
#   linesight_add_module(core
#     SOURCES   error.cc progress.cc          # library sources
#     DEPS      OpenCV::core fmt::fmt         # public link dependencies
#     TESTS     error_test.cc                 # -> one gtest executable linesight_core_test
#     BENCHMARKS progress_benchmark.cc)       # -> one benchmark executable linesight_core_benchmark
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

function(linesight_add_module name)
  cmake_parse_arguments(M "" "" "SOURCES;DEPS;TESTS;TEST_DEPS;BENCHMARKS" ${ARGN})
  set(lib linesight_${name})
  # While a module is being written its CMakeLists may name files that do not exist yet. Outside CI such a
  # module is skipped with a warning so that the rest of the tree still configures; CI (LINESIGHT_STRICT)
  # fails instead.
  foreach(src ${M_SOURCES} ${M_TESTS} ${M_BENCHMARKS})
    if(NOT EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${src})
      if(LINESIGHT_STRICT)
        message(FATAL_ERROR "module ${name}: source ${src} does not exist")
      endif()
      message(WARNING "module ${name}: source ${src} does not exist yet; module skipped")
      return()
    endif()
  endforeach()
  add_library(${lib} STATIC ${M_SOURCES})
  add_library(linesight::${name} ALIAS ${lib})
  target_include_directories(${lib} PUBLIC ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(${lib} PUBLIC ${M_DEPS})
  target_compile_definitions(${lib} PUBLIC
    LINESIGHT_SHARED_DATA_DIR="${LINESIGHT_SHARED_DATA_DIR}"
    LINESIGHT_OPENCV_DATA_DIR="${LINESIGHT_OPENCV_DATA_DIR}")
  linesight_target_warnings(${lib})

  if(LINESIGHT_BUILD_TESTS AND M_TESTS)
    add_executable(${lib}_test ${M_TESTS})
    target_link_libraries(${lib}_test PRIVATE ${lib} ${M_TEST_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
    linesight_target_warnings(${lib}_test)
    gtest_discover_tests(${lib}_test DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 60
                         PROPERTIES LABELS ${name})
  endif()
  if(LINESIGHT_BUILD_BENCHMARKS AND M_BENCHMARKS)
    add_executable(${lib}_benchmark ${M_BENCHMARKS})
    target_link_libraries(${lib}_benchmark PRIVATE ${lib} benchmark::benchmark benchmark::benchmark_main)
    linesight_target_warnings(${lib}_benchmark)
  endif()
endfunction()
