# Host dependencies with a message that names the Debian package to install, instead of
# CMake's bare "Could not find a package configuration file" error.
#   thrustcal_require_package(<find_package name> <Debian package> [find_package args...])
#   thrustcal_require_pkgconfig(<prefix> <pkg-config module> <Debian package>)
# Macros, not functions: find_package's result variables must reach the caller's scope.

set(THRUSTCAL_INSTALL_HINT
    "or run tools/test.sh, which installs every Debian package the project needs")

macro(thrustcal_require_package name debian)
  find_package(${name} ${ARGN} QUIET)
  if(NOT ${name}_FOUND)
    message(FATAL_ERROR
      "thrustcal: the library ${name} was not found.\n"
      "Install it with:  sudo apt-get install ${debian}\n"
      "(${THRUSTCAL_INSTALL_HINT}).")
  endif()
endmacro()

macro(thrustcal_require_pkgconfig prefix module debian)
  find_package(PkgConfig QUIET)
  if(NOT PKG_CONFIG_FOUND)
    message(FATAL_ERROR
      "thrustcal: pkg-config was not found (needed to find ${module}).\n"
      "Install it with:  sudo apt-get install pkg-config\n(${THRUSTCAL_INSTALL_HINT}).")
  endif()
  pkg_check_modules(${prefix} QUIET IMPORTED_TARGET ${module})
  if(NOT ${prefix}_FOUND)
    message(FATAL_ERROR
      "thrustcal: the library ${module} was not found by pkg-config.\n"
      "Install it with:  sudo apt-get install ${debian}\n(${THRUSTCAL_INSTALL_HINT}).")
  endif()
endmacro()
