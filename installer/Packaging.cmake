# CPack: `cpack -G DEB` in the build folder makes mrsns_<version>_amd64.deb
# with mrsns-cli, the GUI `mrsns` (when built), the resources (phantom notes,
# configurations, the sample session, the WebXR client's page) under share/mrsns, the desktop entry and
# the icon. Dependencies are computed from the linked Debian libraries.
# The programs find share/mrsns beside their bin/ folder
# (mrsns::workflow::resourceDirectory), so the package works under any prefix
# and when unpacked with `dpkg -x` (tests/installer).
install(DIRECTORY ${CMAKE_SOURCE_DIR}/resources/ DESTINATION share/mrsns
        PATTERN ".*" EXCLUDE)
install(FILES ${CMAKE_SOURCE_DIR}/installer/mrsns.desktop DESTINATION share/applications)
install(FILES ${CMAKE_SOURCE_DIR}/installer/mrsns.svg DESTINATION share/icons/hicolor/scalable/apps)
# The GUI (app/gui) and mrsns-cli (app/cli) install themselves to bin/.

set(CPACK_PACKAGE_NAME "mrsns")
set(CPACK_PACKAGE_VENDOR "MR-SNS project")
set(CPACK_PACKAGE_CONTACT "MR-SNS developers <mrsns@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Mixed-reality surgical navigation workstation (ultrasound, HMD, robot)")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_GENERATOR "DEB")
set(CPACK_PACKAGING_INSTALL_PREFIX "/usr")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The WebXR client's page imports three.js from Debian's package (served from /usr/share/javascript/three).
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libjs-three (>= 111)")
set(CPACK_DEBIAN_PACKAGE_SECTION "science")
set(CPACK_STRIP_FILES ON)
include(CPack)
