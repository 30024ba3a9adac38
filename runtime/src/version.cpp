#include "skelform/skelform.h"

extern "C" {

uint32_t sf_version(void) { return SF_VERSION; }

const char* sf_result_string(sf_result result) {
  switch (result) {
    case SF_OK: return "SF_OK";
    case SF_ERROR_INVALID_ARGUMENT: return "SF_ERROR_INVALID_ARGUMENT";
    case SF_ERROR_INVALID_DATA: return "SF_ERROR_INVALID_DATA";
    case SF_ERROR_VERSION_MISMATCH: return "SF_ERROR_VERSION_MISMATCH";
    case SF_ERROR_OUT_OF_MEMORY: return "SF_ERROR_OUT_OF_MEMORY";
    case SF_ERROR_IO: return "SF_ERROR_IO";
    case SF_ERROR_UNSUPPORTED: return "SF_ERROR_UNSUPPORTED";
    case SF_ERROR_NOT_READY: return "SF_ERROR_NOT_READY";
    case SF_RESULT_FORCE_U32: break;
  }
  return "SF_ERROR_UNKNOWN";
}

}  // extern "C"
