#include <skelform/skelform.h>
#include <stdio.h>

int main(void) {
  if (sf_version() != SF_VERSION) return 1;
  printf("skelform runtime %u from an installed package\n", (unsigned)sf_version());
  return 0;
}
