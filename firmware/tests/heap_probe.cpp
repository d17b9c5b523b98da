// Negative link test: this image uses the heap, so linking it must fail with the linker-script
// guard's message ("heap allocator linked into firmware"). Never built by default.
#include <cstdlib>

void* volatile g_escape;

int main() {
#if defined(BV_PROBE_NEW)
  g_escape = new int[4];  // an allocation that escapes, so GCC cannot elide it
#else
  g_escape = std::malloc(16);
#endif
  return g_escape != nullptr ? 0 : 1;
}
