// Placement new (construct an object at an address: the unions of work space in core and the
// firmware).
// avr-libc ships no <new>; this is the standard form.
#pragma once
#include <stddef.h>

#if defined(__AVR__)
inline void* operator new(size_t, void* where) noexcept { return where; }
#else
#include <new>
#endif
