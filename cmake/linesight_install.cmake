# Installation: `cmake --install` puts the `linesight` CLI, the static libraries with their headers, a CMake
# package (find_package(linesight) -> linesight::<module>) and a pkg-config file (linesight.pc) under the prefix;
# `cpack -G DEB` packs the same tree for /usr. scripts/check_install.sh builds examples/consumer against both.
include(CMakePackageConfigHelpers)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Binocular stereo vision ranging for power-line inspection robots")

set(LINESIGHT_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/linesight)
get_property(LINESIGHT_MODULES GLOBAL PROPERTY LINESIGHT_MODULES)  # in dependency order
foreach(module ${LINESIGHT_MODULES})
  install(TARGETS linesight_${module} EXPORT linesightTargets
          PUBLIC_HEADER DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/linesight/${module})
endforeach()
install(TARGETS linesight)

# The eval studies' options (eval/ranging_study.h, eval/real_ranging.h) default their dataset root to
# LINESIGHT_SHARED_DATA_DIR: the build tree's data folder, and <prefix>/share/linesight/data once installed.
if(TARGET linesight_eval)
  target_compile_definitions(linesight_eval INTERFACE
    $<INSTALL_INTERFACE:LINESIGHT_SHARED_DATA_DIR="$<INSTALL_PREFIX>/${CMAKE_INSTALL_DATADIR}/linesight/data">)
endif()

# CMake package. Pre-1.0 a minor version may change the API, so only the same 0.x is compatible.
list(TRANSFORM OpenCV_LIBS REPLACE "^opencv_" "" OUTPUT_VARIABLE LINESIGHT_OPENCV_COMPONENTS)
list(JOIN LINESIGHT_OPENCV_COMPONENTS " " LINESIGHT_OPENCV_COMPONENTS)
install(EXPORT linesightTargets NAMESPACE linesight:: DESTINATION ${LINESIGHT_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/linesightConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/linesightConfig.cmake INSTALL_DESTINATION ${LINESIGHT_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/linesightConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/linesightConfig.cmake ${PROJECT_BINARY_DIR}/linesightConfigVersion.cmake
        DESTINATION ${LINESIGHT_CMAKE_DIR})

# pkg-config file, relocatable (paths relative to its own folder). Libraries: dependents before dependencies.
# Flags: the modules' public definitions except the build tree's data folders.
set(LINESIGHT_PC_LIBS)
set(LINESIGHT_PC_DEFINES)
foreach(module ${LINESIGHT_MODULES})
  list(PREPEND LINESIGHT_PC_LIBS -llinesight_${module})
  get_property(defines TARGET linesight_${module} PROPERTY INTERFACE_COMPILE_DEFINITIONS)
  list(FILTER defines EXCLUDE REGEX "\\$<")
  list(TRANSFORM defines PREPEND -D)
  list(APPEND LINESIGHT_PC_DEFINES ${defines})
endforeach()
list(REMOVE_DUPLICATES LINESIGHT_PC_DEFINES)
list(JOIN LINESIGHT_PC_LIBS " " LINESIGHT_PC_LIBS)
list(JOIN LINESIGHT_PC_DEFINES " " LINESIGHT_PC_DEFINES)
set(LINESIGHT_PC_PREFIX /prefix)
cmake_path(RELATIVE_PATH LINESIGHT_PC_PREFIX BASE_DIRECTORY /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig)
configure_file(${PROJECT_SOURCE_DIR}/cmake/linesight.pc.in ${PROJECT_BINARY_DIR}/linesight.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/linesight.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# Debian package: one package `linesight` with everything installed (CLI, headers, static libraries, CMake and
# pkg-config files, and any component added later such as the Python module). Its Depends: the shared
# libraries the CLI needs (dpkg-shlibdeps) and the -dev packages a build against the static libraries needs.
set(CPACK_PACKAGE_NAME linesight)
set(CPACK_PACKAGE_DESCRIPTION "linesight measures distances with a calibrated stereo camera. This package holds \
the linesight command-line tool and the C++ static libraries with their headers, CMake package \
(find_package(linesight)) and pkg-config file (linesight.pc).")
set(CPACK_PACKAGE_CONTACT "linesight maintainers <maintainers@users.noreply.h-seed-e8d883a5.example>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS
    "libopencv-dev (>= 4), libopencv-contrib-dev, libpng-dev, libjpeg-dev, libeigen3-dev (>= 3.3), libceres-dev, libhwy-dev, \
nlohmann-json3-dev (>= 3), libspdlog-dev, libfmt-dev, libboost-graph-dev (>= 1.74), libcpp-httplib-dev, \
pkgconf | pkg-config")
include(CPack)

if(LINESIGHT_BUILD_TESTS)
  # Installs this build, builds examples/consumer against the CMake package and a program against the
  # pkg-config file, and checks the .deb's contents (scripts/check_install.sh); skipped (77) without opencv-doc.
  add_test(NAME installed_package_builds_a_consumer
           COMMAND bash ${PROJECT_SOURCE_DIR}/scripts/check_install.sh ${PROJECT_BINARY_DIR}
                   ${PROJECT_BINARY_DIR}/check_install)
  set_tests_properties(installed_package_builds_a_consumer PROPERTIES SKIP_RETURN_CODE 77 LABELS "package;slow" TIMEOUT 600
                       ENVIRONMENT LINESIGHT_OPENCV_DATA_DIR=${LINESIGHT_OPENCV_DATA_DIR})
endif()
