/* The public header compiles as strict C99 and links against the runtime. */
#include "skelform/skelform.h"

#include <stdio.h>
#include <string.h>

int main(void) {
  if (sf_version() != SF_VERSION) {
    fprintf(stderr, "header version %d, library version %u\n", SF_VERSION, (unsigned)sf_version());
    return 1;
  }
  if (strcmp(sf_result_string(SF_OK), "SF_OK") != 0) return 1;
  if (strcmp(sf_result_string((sf_result)12345), "SF_ERROR_UNKNOWN") != 0) return 1;
  /* Any value of the enum's type from C, a negative one too (the library must not load it as
   * a C++ enum: undefined behaviour, caught by UBSan). */
  if (strcmp(sf_result_string((sf_result)-1), "SF_ERROR_UNKNOWN") != 0) return 1;
  {
    /* Loading from C: zeroed options are the defaults, and bad input is an error code with a
     * message, never a crash. */
    char message[128] = "";
    sf_load_options options;
    sf_asset* asset = NULL;
    memset(&options, 0, sizeof options);
    options.error_message = message;
    options.error_message_capacity = sizeof message;
    if (sf_asset_load_memory("garbage", 7, &options, &asset) != SF_ERROR_INVALID_DATA || asset != NULL) return 1;
    if (message[0] == '\0') return 1;
    if (sf_asset_load_memory(NULL, 0, NULL, &asset) != SF_ERROR_INVALID_ARGUMENT) return 1;
    if (sf_asset_deformable_count(NULL) != 0) return 1;
    sf_asset_destroy(NULL);
  }
  return 0;
}
