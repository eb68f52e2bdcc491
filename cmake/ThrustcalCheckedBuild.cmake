# How the checked tree (THRUSTCAL_SANITIZE, what tools/test.sh builds) keeps its compile time down
# without dropping a test or a sanitizer (docs/testing.md, "Build time of the checked tree"):
#
#  - Test code at -O0. A sanitized test file at -O1 costs about twice its -O0 compile, and a
#    test body is not where the time goes when it runs: the code under test (core, firmware
#    logic, plant, simulator harness, lab) is compiled in its libraries with the tree's flags.
#  - Test executables as unity builds (in the plain tree too): every test file includes
#    GoogleTest and the project's headers, and each file instantiates the same templates again;
#    one translation unit per executable parses and instantiates them once.
#  - Command-line front ends outside a unity library (thrustcal's main.cpp: CLI11 option tables,
#    no computation) at -O0 too: CLI11's templates dominate them. The front ends inside the tool
#    libraries (cli.cpp, *_cli.cpp) join their library's unity batches instead: one batch of six
#    of tools/sim's front ends compiles in 25 CPU s at -O1 where the six files alone took 86 s
#    at -O0.
#  - The tools' libraries as unity builds in batches (thrustcal_unity_libraries, both trees): a
#    tool file spends most of its compile on the headers it shares with its neighbours
#    (nlohmann-json, fmt, Eigen, the standard library), whose inline functions every translation
#    unit compiles again, with the sanitizers' instrumentation in the checked tree.
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

# Test executables under DIR: one unity translation unit each, in every tree (so a name two
# test files both define is a compile error in the developer's tree too, not first in CI's),
# and -O0 in the checked tree.
function(thrustcal_checked_tests dir)
  if(NOT THRUSTCAL_FAST_CHECKED)
    return()
  endif()
  thrustcal_targets_below(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "EXECUTABLE")
      if(THRUSTCAL_SANITIZE)
        target_compile_options(${t} PRIVATE -O0)
      endif()
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
    get_target_property(unity ${t} UNITY_BUILD)
    if(NOT sources OR unity)
      continue()  # a unity library's front ends share its batches (thrustcal_unity_libraries)
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

# The static libraries under DIR as unity builds, THRUSTCAL_UNITY_BATCH files per translation
# unit (0: one per library; 1: off). Both trees: the plain tree that tools/demo.sh builds gains
# as much. A source with its own compile options stays a translation unit of its own (CMake
# leaves such files out of unity sources). Call before thrustcal_checked_cli.
set(THRUSTCAL_UNITY_BATCH 32 CACHE STRING "Tool libraries: source files per unity translation unit (1: no unity build)")
function(thrustcal_unity_libraries dir)
  if(THRUSTCAL_UNITY_BATCH LESS_EQUAL 1 AND NOT THRUSTCAL_UNITY_BATCH EQUAL 0)
    return()
  endif()
  thrustcal_targets_below(${dir} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "STATIC_LIBRARY")
      set_target_properties(${t} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${THRUSTCAL_UNITY_BATCH})
      thrustcal_unity_group_cli(${t})
    endif()
  endforeach()
endfunction()

# A library's command-line sources (those that include CLI11 or a `*cli*.hpp` header) in one
# batch of their own, the others in batches of THRUSTCAL_UNITY_BATCH in source order. CLI11 2.1
# is header-only and its option validators are objects every including translation unit compiles
# again (about 7 CPU s each, sanitized): spread over a library's batches, tools/sim compiled it in
# five of them.
function(thrustcal_unity_group_cli target)
  get_target_property(sources ${target} SOURCES)
  get_target_property(src_dir ${target} SOURCE_DIR)
  set(cli "")
  set(others "")
  foreach(src ${sources})
    if(NOT src MATCHES "\\.cpp$")
      continue()
    endif()
    get_filename_component(path ${src} ABSOLUTE BASE_DIR ${src_dir})
    get_source_file_property(defs ${path} TARGET_DIRECTORY ${target} COMPILE_DEFINITIONS)
    if(defs)
      continue()  # its own compile options: CMake builds it alone anyway
    endif()
    file(STRINGS ${path} includes REGEX "^#include [<\"](CLI/|[^>\"]*cli[a-z_]*\\.hpp)")
    if(includes)
      list(APPEND cli ${path})
    else()
      list(APPEND others ${path})
    endif()
  endforeach()
  list(LENGTH cli n_cli)
  if(n_cli LESS 2 OR THRUSTCAL_UNITY_BATCH EQUAL 0)
    return()  # nothing to gather: CMake's plain batches
  endif()
  set_property(SOURCE ${cli} TARGET_DIRECTORY ${target} PROPERTY UNITY_GROUP cli)
  set(i 0)
  foreach(path ${others})
    math(EXPR batch "${i} / ${THRUSTCAL_UNITY_BATCH}")
    set_property(SOURCE ${path} TARGET_DIRECTORY ${target} PROPERTY UNITY_GROUP batch${batch})
    math(EXPR i "${i} + 1")
  endforeach()
  set_target_properties(${target} PROPERTIES UNITY_BUILD_MODE GROUP)
endfunction()
