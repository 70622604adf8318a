# Installing polyport (cmake --install), the CMake package that external projects build
# component plugins with (find_package(polyport) + polyport::component_api), and the .deb
# (cpack -G DEB in the build folder). Layout under the prefix (GNUInstallDirs):
#
#   bin/                          polyportd, polyportctl
#   lib/                          libpolyport_core.so (the daemon and every plugin share it)
#   lib/polyport/                 the shipped component plugins; an installed polyportd looks
#                                 here after -L and POLYPORT_LIBRARY_PATH, found from its own place
#   lib/cmake/polyport/           polyportConfig.cmake, its version file, the exported targets
#   lib/systemd/system/           polyportd.service (config/polyportd.service)
#   include/polyport/             the core headers (component_api.hpp and what it includes)
#   share/polyport/profiles/      the shipped application and component profiles
#   share/polyport/config/        types, schemas, DDS configurations (the profiles' ../config)
include(CMakePackageConfigHelpers)

set(POLYPORT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/polyport)
set(POLYPORT_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/polyport)

# The component API as plugins link it. In the build polyport_core's include folders are
# its layers' own (core/CMakeLists.txt); installed, they are one include/.
add_library(polyport_component_api INTERFACE)
add_library(polyport::component_api ALIAS polyport_component_api)
target_link_libraries(polyport_component_api INTERFACE polyport_core)
target_include_directories(polyport_core INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
set_target_properties(polyport_core PROPERTIES EXPORT_NAME core)
set_target_properties(polyport_component_api PROPERTIES EXPORT_NAME component_api)

# Installed binaries find libpolyport_core.so relative to themselves, so a prefix can move.
file(RELATIVE_PATH bindir_to_libdir /${CMAKE_INSTALL_BINDIR} /${CMAKE_INSTALL_LIBDIR})
file(RELATIVE_PATH plugindir_to_libdir /${POLYPORT_INSTALL_PLUGINDIR} /${CMAKE_INSTALL_LIBDIR})
set_target_properties(polyportd PROPERTIES INSTALL_RPATH "$ORIGIN/${bindir_to_libdir}")
set_target_properties(polyport_wheelchair PROPERTIES INSTALL_RPATH "$ORIGIN/${plugindir_to_libdir}")

install(TARGETS polyportd polyportctl RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS polyport_core polyport_component_api EXPORT polyportTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS polyport_wheelchair LIBRARY DESTINATION ${POLYPORT_INSTALL_PLUGINDIR})
foreach(layer base types codecs profile runtime)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/${layer}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/profiles/ DESTINATION ${POLYPORT_INSTALL_DATADIR}/profiles)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${POLYPORT_INSTALL_DATADIR}/config
  PATTERN polyportd.service EXCLUDE)

# The unit names the daemon and the default profile by their installed paths, which are
# known only when installing: cpack installs under /usr whatever CMAKE_INSTALL_PREFIX was.
install(CODE "
  set(POLYPORT_BINDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  set(POLYPORT_DATADIR \"\${CMAKE_INSTALL_PREFIX}/${POLYPORT_INSTALL_DATADIR}\")
  configure_file(\"${PROJECT_SOURCE_DIR}/config/polyportd.service\" \"${CMAKE_BINARY_DIR}/packaging/polyportd.service\" @ONLY)
")
install(FILES ${CMAKE_BINARY_DIR}/packaging/polyportd.service DESTINATION lib/systemd/system)

install(EXPORT polyportTargets NAMESPACE polyport:: DESTINATION ${POLYPORT_INSTALL_CMAKEDIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/polyportConfig.cmake.in
  ${CMAKE_BINARY_DIR}/packaging/polyportConfig.cmake
  INSTALL_DESTINATION ${POLYPORT_INSTALL_CMAKEDIR}
  PATH_VARS POLYPORT_INSTALL_PLUGINDIR POLYPORT_INSTALL_DATADIR)
# 0.x: a plugin is built against one minor version (the core's C++ ABI is not frozen yet).
write_basic_package_version_file(${CMAKE_BINARY_DIR}/packaging/polyportConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/packaging/polyportConfig.cmake ${CMAKE_BINARY_DIR}/packaging/polyportConfigVersion.cmake
  DESTINATION ${POLYPORT_INSTALL_CMAKEDIR})

# The .deb: one package, its dependencies found by dpkg-shlibdeps from what the binaries link.
set(CPACK_PACKAGE_NAME polyport)
set(CPACK_PACKAGE_VENDOR polyport)
set(CPACK_PACKAGE_CONTACT "polyport maintainers <polyport@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "runs robot components of different component models as one application")
set(CPACK_PACKAGE_DESCRIPTION "polyportd runs in-process components, Cyclone DDS, Fast DDS, LCM and SocketCAN
applications as one application wired by an XML application profile; polyportctl
looks into and commands a running daemon. Includes the headers and CMake package
for building in-process component plugins (find_package(polyport)).")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# libpolyport_core.so is the package's own: dpkg-shlibdeps finds it in the staging tree.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${CMAKE_INSTALL_LIBDIR})
# Building a plugin against the package needs a compiler and the core headers' own headers.
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "cmake, g++, libeigen3-dev, nlohmann-json3-dev")
include(CPack)
