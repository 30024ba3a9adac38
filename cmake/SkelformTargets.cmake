# Compile settings shared by every target of skelform's own code.
function(skelform_project_code target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(SKELFORM_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
