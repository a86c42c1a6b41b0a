# The Debian package (`make deb`, docs/install.md): CPack's DEB generator over the install rules
# of every target. Dependencies are computed from the binaries with dpkg-shlibdeps (dpkg-dev),
# so they name the exact Debian 12 library packages the build linked.
#
#   /usr/bin/nvstim
#   /usr/share/nvstim/config, /usr/share/nvstim/scenarios      (the data an installed nvstim reads)
#   /usr/share/man/man1/nvstim.1.gz                            (made from the binary's --help)
#   /usr/share/bash-completion/completions/nvstim
#   /usr/lib/x86_64-linux-gnu/gstreamer-1.0/libgstnvstim.so    (rt/gst)
#   /usr/lib/python3/dist-packages/nvstim*.so                  (python/)
#   /usr/share/doc/nvstim/                                     (README, docs)

# The manual page and the completion, made from the built binary's own help text.
find_package(Python3 REQUIRED COMPONENTS Interpreter)
set(NVS_MANUAL_DIR ${PROJECT_BINARY_DIR}/manual)
add_custom_command(
  OUTPUT ${NVS_MANUAL_DIR}/nvstim.1.gz ${NVS_MANUAL_DIR}/nvstim.bash
  COMMAND ${Python3_EXECUTABLE} ${PROJECT_SOURCE_DIR}/packaging/make_manual.py
          $<TARGET_FILE:nvstim> ${NVS_MANUAL_DIR}
  COMMAND gzip -9 -n -f ${NVS_MANUAL_DIR}/nvstim.1
  DEPENDS nvstim ${PROJECT_SOURCE_DIR}/packaging/make_manual.py
  COMMENT "nvstim: manual page and bash completion from --help"
  VERBATIM)
add_custom_target(nvstim_manual ALL DEPENDS ${NVS_MANUAL_DIR}/nvstim.1.gz ${NVS_MANUAL_DIR}/nvstim.bash)
install(FILES ${NVS_MANUAL_DIR}/nvstim.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES ${NVS_MANUAL_DIR}/nvstim.bash DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions
        RENAME nvstim)
install(FILES README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR} PATTERN plots EXCLUDE)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME nvstim)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "nvstim maintainers <nvstim@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "real-time hardware-in-the-loop night-vision stimulator")
set(CPACK_PACKAGE_DESCRIPTION
    "Renders radiometrically correct night scenes (Moon, starlight, airglow, lamps) for the time,
site and platform pose it receives over CAN or serial telemetry, passes them through a physical
image-intensified CCD camera model (or an uncooled microbolometer), and emits the video on V4L2,
files, a GStreamer source element or Python.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The scenarios' generators are Python. The Python module hands frames over as numpy arrays and
# `nvstim sweep` draws its plots with Matplotlib (the table is written without it), so both are
# recommended; gst-launch-1.0 (gstreamer1.0-tools) is suggested for the source element.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3-numpy, python3-matplotlib")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "gstreamer1.0-tools")
set(CPACK_STRIP_FILES ON)
include(CPack)
