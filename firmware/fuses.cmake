# Reads the ATmega2560's fuses and lock bits with avrdude and checks them against what thrustcal
# needs (docs/safety.md, "Fuses and brown-out"). Run by the AVR tree's `fuses-check` target:
#   cmake --build build/avr --target fuses-check        (port: -DAVRDUDE_PORT=..., programmer:
#                                                        -DFUSES_PROGRAMMER=... at configure time)
# or directly:
#   cmake -DAVRDUDE=/usr/bin/avrdude -DPROGRAMMER=wiring -DPORT=/dev/ttyACM0 -DBAUD=115200 \
#         -P firmware/fuses.cmake
#   cmake -DLFUSE=0xFF -DHFUSE=0xD8 -DEFUSE=0xFD -P firmware/fuses.cmake    (values you have)
#
# Reading works through the stock Mega2560 bootloader (-c wiring: its stk500v2 code answers
# CMD_READ_FUSE_ISP and CMD_READ_LOCK_ISP with the chip's own fuse bits); writing fuses needs an
# ISP programmer (usbasp, avrisp2, stk500v2, arduino = ArduinoISP): a program cannot write
# them, the bootloader included. Exit status 1 when a fuse is wrong, with what to do.
#
# Stock Arduino Mega2560 (boards.txt): low 0xFF, high 0xD8, extended 0xFD, lock 0x0F.

cmake_minimum_required(VERSION 3.16)

function(hexval out text)
  string(STRIP "${text}" t)
  string(TOLOWER "${t}" t)
  if(NOT t MATCHES "^(0x)?[0-9a-f][0-9a-f]?$")
    message(FATAL_ERROR "fuses: '${text}' is not a fuse byte (expected e.g. 0xFD)")
  endif()
  string(REGEX REPLACE "^0x" "" t "${t}")
  math(EXPR v "0x${t}")
  set(${out} ${v} PARENT_SCOPE)
endfunction()

if(NOT DEFINED LFUSE OR NOT DEFINED HFUSE OR NOT DEFINED EFUSE)
  if(NOT AVRDUDE)
    message(FATAL_ERROR "fuses: avrdude not found; install it (apt-get install avrdude) or pass "
                        "-DLFUSE=.. -DHFUSE=.. -DEFUSE=.. with values read another way")
  endif()
  if(NOT PROGRAMMER)
    set(PROGRAMMER wiring)
  endif()
  set(args -p m2560 -c ${PROGRAMMER})
  if(PORT)
    list(APPEND args -P ${PORT})
  endif()
  if(BAUD AND PROGRAMMER STREQUAL "wiring")
    list(APPEND args -b ${BAUD})
  endif()
  execute_process(
    COMMAND ${AVRDUDE} ${args} -U lfuse:r:-:h -U hfuse:r:-:h -U efuse:r:-:h -U lock:r:-:h
    OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "fuses: avrdude ${args} failed (exit ${rc}):\n${err}\n"
                        "Check the port (-DAVRDUDE_PORT=...) and that nothing else holds it; "
                        "with -c wiring the board's bootloader must answer (it runs for about a "
                        "second after the reset avrdude causes).")
  endif()
  string(REGEX MATCHALL "0x[0-9a-fA-F]+" bytes "${out}")
  list(LENGTH bytes n)
  if(n LESS 3)
    message(FATAL_ERROR "fuses: could not read three fuse bytes from avrdude; it printed:\n"
                        "${out}\n${err}")
  endif()
  list(GET bytes 0 LFUSE)
  list(GET bytes 1 HFUSE)
  list(GET bytes 2 EFUSE)
  if(n GREATER 3)
    list(GET bytes 3 LOCK)
  endif()
endif()

hexval(l "${LFUSE}")
hexval(h "${HFUSE}")
hexval(e "${EFUSE}")
set(errors "")
set(notes "")

# Extended fuse: BODLEVEL2:0 (bits 2..0). The unused bits 7..3 read 1 or 0 depending on the tool.
math(EXPR bod "${e} & 7")
if(bod EQUAL 5)
  string(APPEND notes "note: " "brown-out detection at 2.7 V (BODLEVEL 101, the stock setting). The datasheet "
                    "guarantees 16 MHz only from 4.5 V, 4.3 V (extended 0xFC) resets before that, "
                    "but a weak USB supply may then trip it" "\n")
elseif(bod EQUAL 4)
  string(APPEND notes "note: " "brown-out detection at 4.3 V (BODLEVEL 100)" "\n")
elseif(bod EQUAL 7)
  string(APPEND errors "error: " "brown-out detection is OFF (BODLEVEL 111): a supply "
                     "dip can leave the chip running garbage with the ESCs connected. Write "
                     "extended fuse 0xFD (2.7 V) with an ISP programmer" "\n")
else()
  string(APPEND errors "error: " "brown-out level BODLEVEL ${bod} (1.8 V) is below what 16 MHz needs, write "
                     "extended fuse 0xFD (2.7 V) with an ISP programmer" "\n")
endif()

# High fuse: OCDEN 7, JTAGEN 6, SPIEN 5, WDTON 4, EESAVE 3, BOOTSZ1:0 2..1, BOOTRST 0 (0 = programmed).
math(EXPR wdton "(${h} >> 4) & 1")
math(EXPR bootrst "${h} & 1")
math(EXPR eesave "(${h} >> 3) & 1")
math(EXPR spien "(${h} >> 5) & 1")
math(EXPR jtagen "(${h} >> 6) & 1")
if(wdton EQUAL 0)
  if(bootrst EQUAL 0)
    string(APPEND errors "error: " "WDTON is programmed (watchdog always on) and the chip starts in a "
                       "bootloader: the stk500v2 bootloader waits about a second for an upload "
                       "without feeding the watchdog and resets in a loop. Write high fuse 0xD8 "
                       "(WDTON unprogrammed), thrustcal switches the watchdog on itself" "\n")
  else()
    string(APPEND notes "note: " "WDTON programmed: the watchdog can never be switched off (fine without a "
                      "bootloader: thrustcal feeds it)" "\n")
  endif()
endif()
if(spien EQUAL 1)
  string(APPEND notes "note: " "SPIEN unprogrammed: ISP programming is disabled, only a high-voltage "
                    "programmer can change the fuses now" "\n")
endif()
if(eesave EQUAL 1)
  string(APPEND notes "note: " "EESAVE unprogrammed (stock): an ISP chip erase also erases the EEPROM, i.e. "
                    "every motor's calibration, save it first (target eeprom-download) or write "
                    "high fuse 0xD0" "\n")
endif()
if(jtagen EQUAL 0)
  string(APPEND notes "note: " "JTAGEN programmed: PF4..PF7 (A4..A7) are the JTAG port, not analog inputs" "\n")
endif()

# Low fuse: CKDIV8 7, CKOUT 6, SUT1:0 5..4, CKSEL3:0 3..0.
math(EXPR ckdiv8 "(${l} >> 7) & 1")
math(EXPR cksel "${l} & 15")
if(ckdiv8 EQUAL 0)
  string(APPEND errors "error: " "CKDIV8 is programmed: the CPU runs at 2 MHz, not the 16 MHz the images are "
                     "built for (ESC pulses and the UART would be 8x off). Write low fuse 0xFF" "\n")
endif()
if(NOT (cksel EQUAL 15 OR cksel EQUAL 14 OR cksel EQUAL 7 OR cksel EQUAL 6))
  string(APPEND errors "error: " "CKSEL ${cksel}: the clock is not the 16 MHz crystal (stock low fuse 0xFF)" "\n")
endif()

math(EXPR lx "${l}" OUTPUT_FORMAT HEXADECIMAL)
math(EXPR hx "${h}" OUTPUT_FORMAT HEXADECIMAL)
math(EXPR ex "${e}" OUTPUT_FORMAT HEXADECIMAL)
set(lock_text "")
if(DEFINED LOCK)
  set(lock_text ", lock ${LOCK}")
endif()
message(STATUS "fuses: low ${lx}, high ${hx}, extended ${ex}${lock_text}")
if(notes)
  message("${notes}")
endif()
if(errors)
  message("${errors}")
  message(FATAL_ERROR "fuses: wrong for thrustcal (see the errors above, docs/safety.md)")
endif()
message(STATUS "fuses: ok for thrustcal")
