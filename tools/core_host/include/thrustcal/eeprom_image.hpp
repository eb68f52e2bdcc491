// core/'s EEPROM codecs (readRecord, writeRecord, readModelV2, writeModelV2, readSettings,
// readParams, writeParams ...) take a Storage type with static readByte/updateByte, as the
// firmware's hal::Eeprom. On the host the bytes are an image in a vector: EepromImage is that
// Storage, over the image a Use binds for its scope (one image at a time; the tools are
// single-threaded, and a Use inside another's scope restores the outer binding when it ends).
//
//   std::vector<uint8_t> image = ...;
//   { tc::EepromImage::Use use(image); tc::writeModelV2<tc::EepromImage>(slot, model); }
//
// A const image binds read-only: decoding never writes, and a write to it is ignored.
#pragma once
#include <stdint.h>

#include <vector>

namespace tc {

class EepromImage {
 public:
  static uint8_t readByte(uint16_t addr) { return (*read_)[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) {
    if (write_ != nullptr) (*write_)[addr] = value;
  }

  class Use {
   public:
    explicit Use(std::vector<uint8_t>& image) : Use(&image, &image) {}
    explicit Use(const std::vector<uint8_t>& image) : Use(&image, nullptr) {}
    ~Use() {
      read_ = outer_read_;
      write_ = outer_write_;
    }
    Use(const Use&) = delete;
    Use& operator=(const Use&) = delete;

   private:
    Use(const std::vector<uint8_t>* read, std::vector<uint8_t>* write)
        : outer_read_(read_), outer_write_(write_) {
      read_ = read;
      write_ = write;
    }
    const std::vector<uint8_t>* outer_read_;
    std::vector<uint8_t>* outer_write_;
  };

 private:
  inline static const std::vector<uint8_t>* read_ = nullptr;
  inline static std::vector<uint8_t>* write_ = nullptr;
};

}  // namespace tc
