// Included once by every host program that runs libsimavr (sim::Board, the bench's probe, the
// HAL and cycle-count harnesses).
//
// Under LeakSanitizer (tools/test.sh builds the host tree with ASan): libsimavr keeps what it
// allocates for its peripherals' IRQ names and the ELF's sections and symbols past
// avr_terminate(). Those allocations are the library's, not ours, so a leak whose stack has a
// libsimavr frame is not reported; every other leak still fails its test.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define THRUSTCAL_LSAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define THRUSTCAL_LSAN 1
#endif
#endif

#ifdef THRUSTCAL_LSAN
// inline + used: emitted in each including file, merged by the linker into one definition.
extern "C" inline __attribute__((used)) const char* __lsan_default_suppressions() {
  return "leak:libsimavr.so\n";
}
#endif
