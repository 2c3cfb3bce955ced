// toml++'s implementation compiled into the fuzz targets, so that the TOML parser is
// instrumented too (coverage and sanitizers); Debian's libtomlplusplus.so is not.
#define TOML_IMPLEMENTATION 1
#include <toml++/toml.h>
