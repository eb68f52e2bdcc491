// The Arduino Mega 2560's header pins: D0..D69 (A0..A15 are D54..D69) and the ATmega2560 port
// pin each is wired to, as the board's schematic and the Arduino core's "mega" variant number
// them. hal/board.hpp checks its tables against this one; the simulator names pins with it
// (`sim console --esc-pins D3,D5,D6,D2`, sim/pin_names.hpp). docs/hardware.md has the same map.
#pragma once
#include <stdint.h>

namespace hal {

struct MegaPin {
  uint8_t arduino;  // D number (0xFF: a port pin the Mega's headers do not carry)
  char port;        // 'A'..'L'
  uint8_t bit;      // 0..7
};

constexpr uint8_t kMegaPinCount = 70;        // D0..D69
constexpr uint8_t kMegaFirstAnalogPin = 54;  // A0 = D54 ... A15 = D69
constexpr uint8_t kNotOnHeader = 0xFF;

// clang-format off
constexpr MegaPin kMegaPins[kMegaPinCount] = {
    {0, 'E', 0},  {1, 'E', 1},  {2, 'E', 4},  {3, 'E', 5},  {4, 'G', 5},  {5, 'E', 3},   // D0 RX0, D1 TX0
    {6, 'H', 3},  {7, 'H', 4},  {8, 'H', 5},  {9, 'H', 6},  {10, 'B', 4}, {11, 'B', 5},
    {12, 'B', 6}, {13, 'B', 7}, {14, 'J', 1}, {15, 'J', 0}, {16, 'H', 1}, {17, 'H', 0},  // D13: the LED
    {18, 'D', 3}, {19, 'D', 2}, {20, 'D', 1}, {21, 'D', 0},                              // D20 SDA, D21 SCL
    {22, 'A', 0}, {23, 'A', 1}, {24, 'A', 2}, {25, 'A', 3}, {26, 'A', 4}, {27, 'A', 5},
    {28, 'A', 6}, {29, 'A', 7}, {30, 'C', 7}, {31, 'C', 6}, {32, 'C', 5}, {33, 'C', 4},
    {34, 'C', 3}, {35, 'C', 2}, {36, 'C', 1}, {37, 'C', 0}, {38, 'D', 7}, {39, 'G', 2},
    {40, 'G', 1}, {41, 'G', 0}, {42, 'L', 7}, {43, 'L', 6}, {44, 'L', 5}, {45, 'L', 4},
    {46, 'L', 3}, {47, 'L', 2}, {48, 'L', 1}, {49, 'L', 0}, {50, 'B', 3}, {51, 'B', 2},
    {52, 'B', 1}, {53, 'B', 0},
    {54, 'F', 0}, {55, 'F', 1}, {56, 'F', 2}, {57, 'F', 3}, {58, 'F', 4}, {59, 'F', 5},  // A0..A7
    {60, 'F', 6}, {61, 'F', 7},
    {62, 'K', 0}, {63, 'K', 1}, {64, 'K', 2}, {65, 'K', 3}, {66, 'K', 4}, {67, 'K', 5},  // A8..A15
    {68, 'K', 6}, {69, 'K', 7},
};
// clang-format on

// The header pin wired to (port, bit), or kNotOnHeader.
constexpr uint8_t megaPinOf(char port, uint8_t bit, uint8_t i = 0) {
  return i >= kMegaPinCount                                       ? kNotOnHeader
         : kMegaPins[i].port == port && kMegaPins[i].bit == bit ? kMegaPins[i].arduino
                                                                 : megaPinOf(port, bit, static_cast<uint8_t>(i + 1));
}

namespace board {
constexpr bool megaPinsNumbered(uint8_t i = 0) {
  return i >= kMegaPinCount || (kMegaPins[i].arduino == i && kMegaPins[i].bit < 8 && kMegaPins[i].port >= 'A' &&
                                kMegaPins[i].port <= 'L' && kMegaPins[i].port != 'I' &&
                                megaPinsNumbered(static_cast<uint8_t>(i + 1)));
}
}  // namespace board
static_assert(board::megaPinsNumbered(), "row i is Di, on a port pin A..L (no I) bit 0..7");

}  // namespace hal
