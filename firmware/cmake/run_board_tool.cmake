# Runs `thrustcal board ARGS...` for the flash-* / eeprom-* targets (cmake -P), and refuses
# clearly when the host tool is not built. Variables: TOOL (path of thrustcal), ARGS (the
# arguments joined with '|').
if(NOT EXISTS "${TOOL}")
  message(FATAL_ERROR
    "${TOOL} is not built; the flash and EEPROM targets run `thrustcal board` (it drives avrdude "
    "and checks the board). Build it first: cmake --preset host && cmake --build --preset host "
    "--target thrustcal (or pass -DTHRUSTCAL_TOOL=/path/to/thrustcal)")
endif()
string(REPLACE "|" ";" args "${ARGS}")
execute_process(COMMAND "${TOOL}" board ${args} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  string(REPLACE ";" " " shown "${args}")
  message(FATAL_ERROR "thrustcal board ${shown}: failed (exit ${rc}); its message is above")
endif()
