#include "skelform/skelform.h"

#include <cstdint>
#include <cstring>

extern "C" {

uint32_t sf_version(void) { return SF_VERSION; }

const char* sf_result_string(sf_result result) {
  // Read as the bits a C caller passed, never as the enum: a C caller may pass any value of
  // the enum's underlying type (-1 included), and loading a value outside sf_result's range
  // as an sf_result is undefined behaviour in C++.
  static_assert(sizeof(sf_result) == sizeof(uint32_t), "sf_result is 32 bits (SF_RESULT_FORCE_U32)");
  uint32_t value;
  std::memcpy(&value, &result, sizeof value);
  switch (value) {
    case SF_OK:
      return "SF_OK";
    case SF_ERROR_INVALID_ARGUMENT:
      return "SF_ERROR_INVALID_ARGUMENT";
    case SF_ERROR_INVALID_DATA:
      return "SF_ERROR_INVALID_DATA";
    case SF_ERROR_VERSION_MISMATCH:
      return "SF_ERROR_VERSION_MISMATCH";
    case SF_ERROR_OUT_OF_MEMORY:
      return "SF_ERROR_OUT_OF_MEMORY";
    case SF_ERROR_IO:
      return "SF_ERROR_IO";
    case SF_ERROR_UNSUPPORTED:
      return "SF_ERROR_UNSUPPORTED";
    case SF_ERROR_NOT_READY:
      return "SF_ERROR_NOT_READY";
    default:
      return "SF_ERROR_UNKNOWN";
  }
}

}  // extern "C"
