# `cmake --install` and the Debian package (CPack):
#   bin/     sceneloc-server, sceneloc-broker, sceneloc, sceneloc-train, sceneloc-gentour,
#            sceneloc-eval
#   /etc/sceneloc/               server.yaml, train.yaml, match.yaml (conffiles in the package)
#   lib/systemd/system/          sceneloc-server.service (deploy/systemd/)
#   share/doc/sceneloc/          the manual (docs/) and the README
#   share/sceneloc/              check-package.sh: the installed package served as the unit says
# and, made by the package's postinst (or by hand after `cmake --install`): the system user
# `sceneloc` and its maps folder /var/lib/sceneloc/maps, the folder the unit serves.
#
#   cmake -S . -B build-pkg -DCMAKE_INSTALL_PREFIX=/usr -DSCENELOC_AVX2=OFF && \
#     cmake --build build-pkg && (cd build-pkg && cpack -G DEB)   # scripts/package.sh
include(GNUInstallDirs)

# With the prefix /usr, GNUInstallDirs puts the settings in /etc and state in /var.
set(SCENELOC_BIN_DIR ${CMAKE_INSTALL_FULL_BINDIR})
set(SCENELOC_CONFIG_DIR ${CMAKE_INSTALL_FULL_SYSCONFDIR}/sceneloc)
set(SCENELOC_STATE_DIR ${CMAKE_INSTALL_FULL_LOCALSTATEDIR}/lib/sceneloc)
set(SCENELOC_MAPS_DIR ${SCENELOC_STATE_DIR}/maps)
set(SCENELOC_DOC_DIR ${CMAKE_INSTALL_FULL_DOCDIR})
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(SCENELOC_UNIT_DIR /lib/systemd/system)
else()
  set(SCENELOC_UNIT_DIR ${CMAKE_INSTALL_PREFIX}/lib/systemd/system)
endif()

install(TARGETS sceneloc-server sceneloc-broker sceneloc sceneloc-train sceneloc-gentour
                sceneloc-eval RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES configs/server.yaml configs/train.yaml configs/match.yaml
        DESTINATION ${SCENELOC_CONFIG_DIR})
configure_file(deploy/systemd/sceneloc-server.service.in sceneloc-server.service @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/sceneloc-server.service DESTINATION ${SCENELOC_UNIT_DIR})
# The package's own check, run inside the image (deploy/check-package.sh).
install(PROGRAMS deploy/check-package.sh DESTINATION ${CMAKE_INSTALL_DATADIR}/sceneloc)
file(GLOB manual ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES README.md ${manual} DESTINATION ${CMAKE_INSTALL_DOCDIR})

# The Debian package: dependencies from the binaries' shared libraries (dpkg-shlibdeps),
# the settings as conffiles (an operator's edits survive upgrades), the user and the maps
# folder made by postinst.
configure_file(deploy/debian/postinst.in debian/postinst @ONLY)
file(WRITE ${PROJECT_BINARY_DIR}/debian/conffiles
     "${SCENELOC_CONFIG_DIR}/server.yaml\n${SCENELOC_CONFIG_DIR}/train.yaml\n"
     "${SCENELOC_CONFIG_DIR}/match.yaml\n")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME sceneloc)
set(CPACK_PACKAGE_VENDOR sceneloc)
set(CPACK_PACKAGE_CONTACT "sceneloc maintainers <sceneloc@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "visual localisation server for mobile robots")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "passwd")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_BINARY_DIR}/debian/postinst ${PROJECT_SOURCE_DIR}/deploy/debian/prerm
    ${PROJECT_SOURCE_DIR}/deploy/debian/postrm ${PROJECT_BINARY_DIR}/debian/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_STRIP_FILES ON)
include(CPack)
