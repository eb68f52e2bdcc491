// Order statistics for core/: the one sort, the one monotone (isotonic) fit and the one median
// of small arrays that the curve builder (v1) and the model v2 fitter share. Templates over the
// element or the block store, so each caller keeps its own number format and work space (no
// heap, no recursion, no extra memory); the algorithm is written once here.
// (The running median of the ADC windows is tc::MedianFilter, median_filter.hpp: it keeps a
// sorted window up to date sample by sample instead of sorting.)
#pragma once
#include <stdint.h>

namespace tc {

// Stable insertion sort of a[0..n) by `less(x, y)` (true when x must come before y). Linear
// time on sorted input, which is what a sweep delivers (PWM ascending); quadratic at worst.
template <class T, class Less>
void insertionSort(T* a, uint16_t n, Less less) {
  for (uint16_t i = 1; i < n; ++i) {
    const T v = a[i];
    uint16_t j = i;
    while (j > 0 && less(v, a[j - 1])) {
      a[j] = a[j - 1];
      --j;
    }
    a[j] = v;
  }
}

// Ascending by operator<.
template <class T>
void insertionSort(T* a, uint16_t n) {
  insertionSort(a, n, [](const T& x, const T& y) { return x < y; });
}

// Median of a[0..n), n >= 1, sorting a in place: the middle value for an odd n, the mean of
// the two middle values for an even n (rounded half up for non-negative values, as int32
// division rounds toward zero).
template <class T>
int32_t medianInPlace(T* a, uint16_t n) {
  insertionSort(a, n);
  const uint16_t mid = static_cast<uint16_t>(n / 2);
  if (n & 1) return a[mid];
  return (static_cast<int32_t>(a[mid - 1]) + a[mid] + 1) / 2;
}

// Pool adjacent violators: the non-decreasing sequence closest (least squares, weighted as
// the Pool weighs its points) to points 0..n-1 taken in order. Blocks of pooled points form a
// stack kept by the caller at indices 0..blocks-1 of its own arrays: block k never lies above
// point k, so a point is read (pool.point(i)) before its index can be reused for a block, and
// filling the blocks from the last one backwards never overwrites a block still to be read.
// The Pool provides
//   Block point(uint16_t i)                     point i as a block of one
//   bool above(const Block& lower, const Block& upper)  lower's mean > upper's: a violation
//   Block merge(const Block& lower, const Block& upper)
//   void keep(uint16_t k, const Block& b) / Block kept(uint16_t k)   the stack
//   uint16_t points(const Block& b)             points in the block
//   void fill(uint16_t first, uint16_t end, const Block& b)   points [first, end) get b's mean
// Returns the number of merges (0: the points were non-decreasing already).
template <class Pool>
uint16_t poolAdjacentViolators(Pool& pool, uint16_t n) {
  uint16_t blocks = 0;
  uint16_t merges = 0;
  for (uint16_t i = 0; i < n; ++i) {
    typename Pool::Block cur = pool.point(i);
    while (blocks > 0) {
      const typename Pool::Block lower = pool.kept(static_cast<uint16_t>(blocks - 1));
      if (!pool.above(lower, cur)) break;
      cur = pool.merge(lower, cur);
      --blocks;
      ++merges;
    }
    pool.keep(blocks, cur);
    ++blocks;
  }
  uint16_t end = n;
  for (uint16_t b = blocks; b-- > 0;) {
    const typename Pool::Block blk = pool.kept(b);
    const uint16_t first = static_cast<uint16_t>(end - pool.points(blk));
    pool.fill(first, end, blk);
    end = first;
  }
  return merges;
}

}  // namespace tc
