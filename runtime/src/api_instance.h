// What the instance half of the C API shares between its files (api_instance.cpp: creation,
// handle sets and poses; api_evaluate.cpp: evaluation; api_output.cpp: writing the output):
// the refusal with a message on the instance, and the boundary that turns every exception
// into an sf_result. Private to the runtime.
#pragma once

#include "instance.h"

#include <new>
#include <stdexcept>

namespace skelform::runtime {

// Writes the printf-style message into the instance and returns `result`.
sf_result fail(const sf_instance* instance, sf_result result, const char* format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

// Runs `body` with every exception turned into a result and a message on the instance.
template <class Body>
sf_result guarded(const sf_instance* instance, const char* call, Body&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return fail(instance, SF_ERROR_OUT_OF_MEMORY, "%s: out of memory", call);
  } catch (const std::invalid_argument& e) {
    return fail(instance, SF_ERROR_INVALID_ARGUMENT, "%s: %s", call, e.what());
  } catch (const std::exception& e) {
    return fail(instance, SF_ERROR_INVALID_DATA, "%s: %s", call, e.what());
  } catch (...) {
    return fail(instance, SF_ERROR_INVALID_DATA, "%s: unknown error", call);
  }
}

}  // namespace skelform::runtime
