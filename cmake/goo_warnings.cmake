# goo::warnings: the warning flags every target of ours links (PRIVATE).
# (-Wnull-dereference is left out: GCC 12 reports false positives inside
# libstdc++ stream buffers at -O3.)
add_library(goo_warnings INTERFACE)
add_library(goo::warnings ALIAS goo_warnings)
target_compile_options(goo_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
  -Wcast-align -Woverloaded-virtual -Wconversion -Wsign-conversion
  -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
  -Wmisleading-indentation -Wduplicated-cond -Wlogical-op)
if(GOO_WERROR)
  target_compile_options(goo_warnings INTERFACE -Werror)
endif()
