// Running median over an odd window (1..201 samples), cheap enough for every ADC sample on the
// ATmega2560, whichever way it is used: queried every few pushes, each push keeps a sorted
// array up to date (one insertion and one removal, O(window) word moves); pushed kEagerPushes
// times or more without a query, pushes only store and the next query sorts the window once (a
// Shell sort). No division, no heap, no recursion. Its costs on the ATmega2560 are measured by
// tests/core/avr_cycles.sh (docs/results.md).
#pragma once
#include <stdint.h>

namespace tc {

// Size-independent part (ETL style): the code exists once, whatever the window.
class MedianFilterBase {
 public:
  // Pushes without a query after which the sorted array is no longer kept up to date.
  static constexpr uint8_t kEagerPushes = 8;
  // Forgets every sample.
  void reset();
  // Adds a sample; once the window is full the oldest sample leaves.
  void push(uint16_t sample);
  // Median of the samples held (lower median while fewer than `window` samples and their
  // count is even). Returns 0 when empty: check count() first.
  uint16_t median() const;
  // Mean of the middle `central` samples held (the median's neighbourhood in rank: a trimmed
  // mean, as robust to spikes as the median while the spikes stay outside it), in 1/16 of a
  // sample unit, rounded: between the integer readings a median is stuck to when the noise
  // dithers them. central must be odd and <= count() (count() odd; clamped otherwise); 1 gives
  // the median * 16. One 32/16 division; no division when central is 1.
  uint16_t centralMeanQ4(uint16_t central) const;
  uint16_t count() const { return count_; }
  uint16_t window() const { return window_; }
  bool full() const { return count_ == window_; }

 protected:
  MedianFilterBase(uint16_t* sorted, uint16_t* ring, uint16_t window)
      : sorted_(sorted), ring_(ring), window_(window) {}

 private:
  // The samples held, ascending (sorting them on the first query after a push).
  const uint16_t* sorted() const;

  uint16_t* sorted_;  // a sorted copy of the ring, valid while sorted_valid_
  uint16_t* ring_;    // the samples held, oldest at head_
  uint16_t window_;
  uint16_t count_ = 0;
  uint16_t head_ = 0;
  mutable bool sorted_valid_ = true;
  mutable uint8_t unqueried_ = 0;  // pushes since the last query, up to kEagerPushes
};

template <uint16_t Window>
class MedianFilter : public MedianFilterBase {
  static_assert(Window % 2 == 1, "median window must be odd");
  static_assert(Window >= 1 && Window <= 201, "median window must be 1..201");

 public:
  MedianFilter() : MedianFilterBase(sorted_storage_, ring_storage_, Window) {}
  MedianFilter(const MedianFilter&) = delete;
  MedianFilter& operator=(const MedianFilter&) = delete;

 private:
  uint16_t sorted_storage_[Window];
  uint16_t ring_storage_[Window];
};

}  // namespace tc
