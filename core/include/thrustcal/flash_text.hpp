// Constant texts that stay in flash on the AVR (PSTR) and are plain strings on the host.
// A function returning TC_FLASH_TEXT("...") returns a flash address on the AVR: print it with
// hal::Uart::printP (firmware), never with a RAM string routine. On the host it is an ordinary
// C string.
#pragma once

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define TC_FLASH_TEXT(s) PSTR(s)
#else
#define TC_FLASH_TEXT(s) (s)
#endif
