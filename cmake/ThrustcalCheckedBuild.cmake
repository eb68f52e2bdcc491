# How the checked tree (THRUSTCAL_SANITIZE, what tools/test.sh builds) keeps its compile time down
# without dropping a test or a sanitizer (docs/testing.md, "Build time of the checked tree"):
#
#  - Test code at -O0. A sanitized test file at -O1 costs about twice its -O0 compile, and a
#    test body is not where the time goes when it runs: the code under test (core, firmware
#    logic, plant, simulator harness, lab) is compiled in its libraries with the tree's flags.
#  - Test executables as unity builds: every test file includes GoogleTest and the project's
#    headers, and each file instantiates the same templates again; one translation unit per
#    executable parses and instantiates them once.
#  - Command-line front ends (a tool folder's cli.cpp or *_cli.cpp and thrustcal's main.cpp:
#    CLI11 option tables, no computation) at -O0 too: CLI11's templates dominate them.
# Every object is still built with -fsanitize=address,undefined and line tables (-g1).
# -DTHRUSTCAL_FAST_CHECKED=OFF builds the checked tree without these (to compare, or to debug a
# test at -O1).
option(THRUSTCAL_FAST_CHECKED "Checked tree: test code and CLI front ends at -O0, unity test builds" ON)

# thrustcal_targets_below(DIR OUT): every target defined in DIR and its subdirectories.
function(thrustcal_targets_below dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub ${subdirs})
    thrustcal_targets_below(${sub} below)
    list(APPEND targets ${below})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# Test executables under DIR: -O0 and one unity translation unit each.
function(thrustcal_checked_tests dir)
  if(NOT THRUSTCAL_SANITIZE OR NOT THRUSTCAL_FAST_CHECKED)
    return()
  endif()
  thrustcal_targets_below(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "EXECUTABLE")
      target_compile_options(${t} PRIVATE -O0)
      set_target_properties(${t} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 0)
    endif()
  endforeach()
endfunction()

# The command-line front ends under DIR (files named cli.cpp or *_cli.cpp): -O0.
function(thrustcal_checked_cli dir)
  if(NOT THRUSTCAL_SANITIZE OR NOT THRUSTCAL_FAST_CHECKED)
    return()
  endif()
  thrustcal_targets_below(${dir} targets)
  foreach(t ${targets})
    get_target_property(sources ${t} SOURCES)
    get_target_property(source_dir ${t} SOURCE_DIR)
    if(NOT sources)
      continue()
    endif()
    foreach(src ${sources})
      if(src MATCHES "(^|/|_)cli\\.cpp$" OR (t STREQUAL "thrustcal" AND src MATCHES "main\\.cpp$"))
        if(NOT IS_ABSOLUTE ${src})
          set(src ${source_dir}/${src})
        endif()
        set_source_files_properties(${src} TARGET_DIRECTORY ${t} PROPERTIES COMPILE_OPTIONS -O0)
      endif()
    endforeach()
  endforeach()
endfunction()
