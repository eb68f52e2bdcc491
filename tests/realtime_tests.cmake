# Included by ctest after the GoogleTest discovery scripts of tests/hil and tests/board: labels
# `realtime` the tests that run a simulated board behind a pseudo-terminal paced to the wall
# clock (a client on the host, avrdude or `thrustcal board`, talks to it as to a real board).
# They spend most of their time waiting, not computing, so tools/test.sh runs them beside the
# CPU-bound tests instead of in their slots (docs/testing.md, "Test run time").
set(realtime_pattern
    "^(ModelV2Hil\\.ReadRunFlies|ReadRunLiftoff\\.|BoardStory\\.|SimulatedBoard\\.|BoardCalibrate\\.)")
get_cmake_property(variables VARIABLES)
foreach(list_variable IN LISTS variables)
  if(NOT list_variable MATCHES "_TESTS$")
    continue()
  endif()
  # The label the folder's discovery gave (ctest has no get_test_property): tests/board's
  # `board`, tests/hil's `hil`.
  set(folder_label hil)
  if(list_variable MATCHES "^board_")
    set(folder_label board)
  endif()
  foreach(test_name IN LISTS ${list_variable})
    if(test_name MATCHES "${realtime_pattern}")
      set_tests_properties("${test_name}" PROPERTIES LABELS "${folder_label};realtime")
    endif()
  endforeach()
endforeach()
