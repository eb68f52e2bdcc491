# Included by ctest after each test folder's GoogleTest discovery scripts: gives the tests that
# take seconds a COST, so that ctest starts them first (the shards and the unit-test executables
# get theirs in CMake). ctest orders a parallel run by cost, most expensive first; it learns costs
# from earlier runs of the same tree (Testing/Temporary/CTestCostData.txt), but a clean clone has
# none, and then the folders' tests start in declaration order: in the clean-clone CI the read_run
# console fuzz (15 s) started last and ran alone on one core at the end (docs/testing.md, "Test
# order"). The figures are seconds of the checked tree's tests on two cores, a scheduling hint
# only: a renamed test merely loses its place in the order, and ctest replaces these figures by
# what it measured once a tree has run.
set(thrustcal_test_costs
  # CPU-bound simulations (ctest -LE realtime)
  "^BenchSimulatedSections\\.Calibration" 30
  "^BenchSimulatedSections\\." 22
  "^ConsoleFuzz\\.ReadRun" 16
  "^ThesisToV2PowerCut\\." 10
  "^BenchFastCalibration\\." 9
  "^SwapHil\\.ForceMode" 14
  "^.*StoreV2PowerCut\\.EveryCut" 6.5
  "^ConsoleFuzz\\.GatherStore" 6.4
  "^(BenchFlySection|BenchDynamicsSection)\\." 5.8
  "^(AvrHalSimFrameRate|SwapHil|ModelV2Hil|SettleAuto)\\." 3.5
  # paced to the wall clock (ctest -L realtime, run beside the others)
  "^(BoardStory\\.FromAStock|ModelV2Hil\\.ReadRunFlies)" 58
  "^ReadRunLiftoff\\." 39
  "^(SimulatedBoard|BoardCalibrate)\\." 10)
get_cmake_property(thrustcal_variables VARIABLES)
foreach(list_variable IN LISTS thrustcal_variables)
  if(NOT list_variable MATCHES "_TESTS$")
    continue()
  endif()
  foreach(test_name IN LISTS ${list_variable})
    set(pairs ${thrustcal_test_costs})
    while(pairs)
      list(POP_FRONT pairs pattern cost)
      if(test_name MATCHES "${pattern}")
        set_tests_properties("${test_name}" PROPERTIES COST ${cost})
        break()
      endif()
    endwhile()
  endforeach()
endforeach()
