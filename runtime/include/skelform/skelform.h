/* skelform — skeleton-driven mesh deformation runtime, public C API.
 *
 * This header is plain C99 and C++ compatible. It is the runtime's manual: every function is
 * documented where it is declared.
 *
 * Conventions (stated once for the whole API):
 * - Units are those of the glTF asset (glTF says metres; skelform never rescales).
 * - Matrices are column-major 4x4 float[16], as glTF stores them.
 * - No call throws, aborts or exits on bad input: every call returns an sf_result.
 *
 * Status: this revision ships the version and result-code part of the API. Asset loading,
 * instances and evaluation arrive with the runtime (see docs/).
 */
#ifndef SKELFORM_SKELFORM_H
#define SKELFORM_SKELFORM_H

#include <stddef.h>
#include <stdint.h>

#if defined(SF_SHARED_LIBRARY)
#  if defined(_WIN32)
#    if defined(SF_BUILDING_LIBRARY)
#      define SF_API __declspec(dllexport)
#    else
#      define SF_API __declspec(dllimport)
#    endif
#  else
#    define SF_API __attribute__((visibility("default")))
#  endif
#else
#  if defined(SF_BUILDING_LIBRARY) && !defined(_WIN32)
#    define SF_API __attribute__((visibility("default")))
#  else
#    define SF_API
#  endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Version of this header. sf_version() returns the version of the linked library; a
 * program may compare the two to detect a header/library mismatch. */
#define SF_VERSION_MAJOR 0
#define SF_VERSION_MINOR 1
#define SF_VERSION_PATCH 0
/* One integer, comparable: major * 10000 + minor * 100 + patch. */
#define SF_VERSION (SF_VERSION_MAJOR * 10000 + SF_VERSION_MINOR * 100 + SF_VERSION_PATCH)

/* Result of every call. Values are stable across versions; new codes are only appended. */
typedef enum sf_result {
  SF_OK = 0,
  SF_ERROR_INVALID_ARGUMENT = 1, /* a null pointer, a count or stride out of range */
  SF_ERROR_INVALID_DATA = 2,     /* the asset's data is corrupt or inconsistent */
  SF_ERROR_VERSION_MISMATCH = 3, /* the asset needs a newer runtime (newer major version) */
  SF_ERROR_OUT_OF_MEMORY = 4,    /* an allocation failed */
  SF_ERROR_IO = 5,               /* a file could not be read */
  SF_ERROR_UNSUPPORTED = 6,      /* valid data that this runtime does not handle */
  SF_RESULT_FORCE_U32 = 0x7fffffff
} sf_result;

/* Version of the linked library, in the SF_VERSION encoding. Thread-safe. */
SF_API uint32_t sf_version(void);

/* A static, human-readable name for a result code ("SF_OK", "SF_ERROR_INVALID_DATA", ...).
 * Unknown values give "SF_ERROR_UNKNOWN". Never returns NULL. Thread-safe. */
SF_API const char* sf_result_string(sf_result result);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* SKELFORM_SKELFORM_H */
