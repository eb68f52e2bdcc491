// Running median: a ring buffer remembers arrival order, a sorted array answers the median.
// Two ways to keep the sorted array, chosen by how the filter is used:
//  - queried often (read_run and fly: four battery readings, then the median, every frame):
//    each push updates the sorted array in place: two binary searches and one shift of the
//    elements between the leaving and the arriving sample, O(window) moves, no division;
//  - filled and then queried (gather_store: 201 load-cell readings, one median): after
//    kEagerPushes pushes without a query the sorted array is given up, pushes only store, and
//    the next query sorts the ring once (a Shell sort). Keeping 201 readings sorted as they
//    arrived took ~1,500 cycles a reading, 74 % of gather_store's awake time in a sweep; one
//    sort is ~60,000 cycles for the 201 (tests/core/avr_cycles.sh).
#include "thrustcal/median_filter.hpp"

namespace tc {

namespace {

// First index in sorted[0..n) whose value is >= v.
uint16_t lowerBound(const uint16_t* sorted, uint16_t n, uint16_t v) {
  uint16_t lo = 0;
  uint16_t hi = n;
  while (lo < hi) {
    const uint16_t mid = static_cast<uint16_t>(lo + ((hi - lo) >> 1));
    if (sorted[mid] < v) {
      lo = static_cast<uint16_t>(mid + 1);
    } else {
      hi = mid;
    }
  }
  return lo;
}

// First index in sorted[0..n) whose value is > v.
uint16_t upperBound(const uint16_t* sorted, uint16_t n, uint16_t v) {
  uint16_t lo = 0;
  uint16_t hi = n;
  while (lo < hi) {
    const uint16_t mid = static_cast<uint16_t>(lo + ((hi - lo) >> 1));
    if (sorted[mid] <= v) {
      lo = static_cast<uint16_t>(mid + 1);
    } else {
      hi = mid;
    }
  }
  return lo;
}

// Moves [first + 1, last] to [first, last - 1]. Pointer loops compile to auto-increment
// loads and stores on avr-gcc, faster than indexed loops (tests/core/avr_cycles.sh compares).
void shiftLeft(uint16_t* first, uint16_t* last) {
  while (first < last) {
    *first = first[1];
    ++first;
  }
}

// Moves [first, last - 1] to [first + 1, last].
void shiftRight(uint16_t* first, uint16_t* last) {
  while (last > first) {
    *last = last[-1];
    --last;
  }
}


// Shell sort, ascending, with Ciura's gaps (the best known for up to a few hundred values): no
// recursion, no extra memory; pointer loops, which avr-gcc turns into auto-increment loads and
// stores.
void shellSort(uint16_t* a, uint16_t n) {
  static const uint8_t kGaps[] = {132, 57, 23, 10, 4, 1};
  for (uint8_t g = 0; g < sizeof kGaps; ++g) {
    const uint16_t gap = kGaps[g];
    if (gap >= n) continue;
    for (uint16_t* i = a + gap; i < a + n; ++i) {
      const uint16_t v = *i;
      uint16_t* j = i;
      while (j >= a + gap && j[-gap] > v) {
        *j = j[-gap];
        j -= gap;
      }
      *j = v;
    }
  }
}

}  // namespace

void MedianFilterBase::reset() {
  count_ = 0;
  head_ = 0;
  sorted_valid_ = true;  // nothing held: sorted
  unqueried_ = 0;
}

void MedianFilterBase::push(uint16_t sample) {
  if (unqueried_ < kEagerPushes) {
    ++unqueried_;
  } else {
    sorted_valid_ = false;  // filled, not queried: the next query sorts
  }
  if (count_ < window_) {
    // Filling up: head_ stays 0, the ring is written in order.
    ring_[count_] = sample;
    if (sorted_valid_) {
      const uint16_t pos = upperBound(sorted_, count_, sample);
      shiftRight(sorted_ + pos, sorted_ + count_);
      sorted_[pos] = sample;
    }
    ++count_;
    return;
  }
  // Full: the oldest sample leaves, the new one takes its ring slot.
  const uint16_t oldest = ring_[head_];
  ring_[head_] = sample;
  head_ = static_cast<uint16_t>(head_ + 1);
  if (head_ == window_) head_ = 0;
  if (!sorted_valid_ || oldest == sample) return;  // not kept, or unchanged

  uint16_t out = lowerBound(sorted_, count_, oldest);  // sorted_[out] == oldest
  if (sample > oldest) {
    // The new sample goes to the right: shift (out, dest) one to the left.
    const uint16_t dest = upperBound(sorted_, count_, sample);  // > out
    const uint16_t last = static_cast<uint16_t>(dest - 1);
    shiftLeft(sorted_ + out, sorted_ + last);
    sorted_[last] = sample;
  } else {
    // The new sample goes to the left: shift [dest, out) one to the right.
    const uint16_t dest = upperBound(sorted_, out, sample);
    shiftRight(sorted_ + dest, sorted_ + out);
    sorted_[dest] = sample;
  }
}

const uint16_t* MedianFilterBase::sorted() const {
  unqueried_ = 0;
  if (!sorted_valid_) {
    for (uint16_t i = 0; i < count_; ++i) sorted_[i] = ring_[i];
    shellSort(sorted_, count_);
    sorted_valid_ = true;
  }
  return sorted_;
}

uint16_t MedianFilterBase::centralMeanQ4(uint16_t central) const {
  if (count_ == 0) return 0;
  if (central > count_) central = count_;
  if (central == 0) central = 1;
  // The same lower index as median() for odd counts; central values symmetric around it.
  const uint16_t first = static_cast<uint16_t>(((count_ - 1u) >> 1) - ((central - 1u) >> 1));
  const uint16_t* sorted_values = sorted();
  uint32_t sum = 0;
  for (uint16_t i = 0; i < central; ++i) sum += sorted_values[first + i];
  return static_cast<uint16_t>((sum * 16u + central / 2u) / central);
}

uint16_t MedianFilterBase::median() const {
  if (count_ == 0) return 0;
  // Odd count: the middle; even count (only while filling): the lower of the two middles.
  return sorted()[(count_ - 1u) >> 1];
}

}  // namespace tc
