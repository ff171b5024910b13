# SPDX-License-Identifier: MIT
# Install rules: the shared library (and libpkss.a with PKSS_BUILD_STATIC),
# the public header, the CMake package (find_package(pkss 1.0) gives
# pkss::pkss, and pkss::pkss_static when installed) and pkss.pc.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PKSS_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/pkss" CACHE STRING
    "Install folder of pkssConfig.cmake, relative to the prefix")

install(TARGETS pkss EXPORT pkssTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES "${PROJECT_SOURCE_DIR}/include/pkss.h" "${PROJECT_SOURCE_DIR}/include/pkss_io.h"
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT pkssTargets NAMESPACE pkss:: DESTINATION "${PKSS_CMAKE_DIR}")
install(FILES "${PROJECT_SOURCE_DIR}/LICENSE" "${PROJECT_SOURCE_DIR}/docs/compatibility.md"
        DESTINATION "${CMAKE_INSTALL_DOCDIR}")

# Its own export: a consumer that never installed the static library gets
# a package without pkss::pkss_static rather than a broken one.
if(PKSS_BUILD_STATIC)
  install(TARGETS pkss_static EXPORT pkssStaticTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(EXPORT pkssStaticTargets NAMESPACE pkss:: DESTINATION "${PKSS_CMAKE_DIR}")
endif()

configure_package_config_file(
  "${PROJECT_SOURCE_DIR}/cmake/pkssConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/pkssConfig.cmake"
  INSTALL_DESTINATION "${PKSS_CMAKE_DIR}")
# 1.x consumers accept any 1.y >= the one they ask for (docs/compatibility.md).
write_basic_package_version_file(
  "${PROJECT_BINARY_DIR}/pkssConfigVersion.cmake"
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES "${PROJECT_BINARY_DIR}/pkssConfig.cmake"
              "${PROJECT_BINARY_DIR}/pkssConfigVersion.cmake"
        DESTINATION "${PKSS_CMAKE_DIR}")

# pkg-config: paths relative to the .pc file (${pcfiledir}) so that
# `cmake --install build --prefix X` and a moved tree both stay right.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(PKSS_PC_LIBDIR "${CMAKE_INSTALL_LIBDIR}")
else()
  set(PKSS_PC_LIBDIR "\${prefix}/${CMAKE_INSTALL_LIBDIR}")
endif()
if(IS_ABSOLUTE "${CMAKE_INSTALL_INCLUDEDIR}")
  set(PKSS_PC_INCLUDEDIR "${CMAKE_INSTALL_INCLUDEDIR}")
else()
  set(PKSS_PC_INCLUDEDIR "\${prefix}/${CMAKE_INSTALL_INCLUDEDIR}")
endif()
# from <prefix>/<libdir>/pkgconfig back up to <prefix>
file(RELATIVE_PATH PKSS_PC_UP "/root/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/root")
string(REGEX REPLACE "/$" "" PKSS_PC_UP "${PKSS_PC_UP}")
set(PKSS_PC_LIBS_PRIVATE "-lm -pthread")
if(CMAKE_DL_LIBS)
  string(APPEND PKSS_PC_LIBS_PRIVATE " -l${CMAKE_DL_LIBS}")
endif()
configure_file("${PROJECT_SOURCE_DIR}/cmake/pkss.pc.in"
               "${PROJECT_BINARY_DIR}/pkss.pc" @ONLY)
install(FILES "${PROJECT_BINARY_DIR}/pkss.pc"
        DESTINATION "${CMAKE_INSTALL_LIBDIR}/pkgconfig")
