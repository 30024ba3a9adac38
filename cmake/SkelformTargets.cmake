# Compile settings shared by every target of skelform's own code.
function(skelform_project_code target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(SKELFORM_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  # The runtime refines the rest control mesh to the baker's bits (the DSS frame of the rest
  # pose, asset_test "the baker's bits"), which holds only if both evaluate every float
  # expression as written. GCC and Clang fuse a*b+c into one rounding wherever the target has
  # FMA (-march=native or x86-64-v3 on any recent x86, every ARM64) unless told not to.
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -ffp-contract=off)
  endif()
endfunction()
