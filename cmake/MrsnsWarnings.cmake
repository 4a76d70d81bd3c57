# Warning flags shared by every target of the project. (-Wnull-dereference is
# left out: it reports false positives inside Eigen at -O2/-O3.)
add_library(mrsns_warnings INTERFACE)
target_compile_options(mrsns_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wnon-virtual-dtor
    -Wcast-align -Woverloaded-virtual -Wimplicit-fallthrough>
  $<$<CXX_COMPILER_ID:GNU>:-Wshadow=local>
  $<$<CXX_COMPILER_ID:Clang>:-Wshadow-uncaptured-local>
  # GCC 12 reports std::string concatenation in libstdc++ as overlapping
  # memcpy at -O2/-O3 (GCC PR 105651, a false positive fixed in GCC 13).
  $<$<AND:$<CXX_COMPILER_ID:GNU>,$<VERSION_LESS:$<CXX_COMPILER_VERSION>,13>>:-Wno-restrict>)
# In a unity build every source is an included file, and GCC reports a class
# with a member of a type from that file's anonymous namespace as it would in
# a header (-Wsubobject-linkage); here it is one translation unit's own type.
if(MRSNS_UNITY_BUILD)
  target_compile_options(mrsns_warnings INTERFACE $<$<CXX_COMPILER_ID:GNU>:-Wno-subobject-linkage>)
endif()
if(MRSNS_WERROR)
  target_compile_options(mrsns_warnings INTERFACE $<$<CXX_COMPILER_ID:GNU,Clang>:-Werror>)
endif()
