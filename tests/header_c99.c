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
  return 0;
}
