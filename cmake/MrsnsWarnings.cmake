# Warning flags shared by every target of the project. (-Wnull-dereference is
# left out: it reports false positives inside Eigen at -O2/-O3.)
add_library(mrsns_warnings INTERFACE)
target_compile_options(mrsns_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow=local -Wnon-virtual-dtor
    -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough>)
if(MRSNS_WERROR)
  target_compile_options(mrsns_warnings INTERFACE $<$<CXX_COMPILER_ID:GNU,Clang>:-Werror>)
endif()
