# CPack: `cpack -G DEB` in the build folder makes mrsns_<version>_amd64.deb
# with mrsns-cli (the GUI, desktop entry and sample session join it in later
# issues). Dependencies are computed from the linked Debian libraries.
set(CPACK_PACKAGE_NAME "mrsns")
set(CPACK_PACKAGE_VENDOR "MR-SNS project")
set(CPACK_PACKAGE_CONTACT "MR-SNS developers <mrsns@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Mixed-reality surgical navigation workstation (ultrasound, HMD, robot)")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_GENERATOR "DEB")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION "science")
include(CPack)
