#include "tests/support/alloc_counter.hpp"

#include <cerrno>
#include <cstddef>

namespace {
thread_local bool t_counting = false;
thread_local std::int64_t t_allocations = 0;

inline void Count() {
  if (t_counting) ++t_allocations;
}
}  // namespace

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
// Sanitizers own malloc; they report allocations through this hook instead.
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
namespace {
void OnMalloc(const volatile void*, std::size_t) { Count(); }
void OnFree(const volatile void*) {}
const int kHooksInstalled = __sanitizer_install_malloc_and_free_hooks(OnMalloc, OnFree);
}  // namespace
#else
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) {
  Count();
  return __libc_malloc(n);
}
void* calloc(std::size_t count, std::size_t size) {
  Count();
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t n) {
  Count();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t alignment, std::size_t n) {
  Count();
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
  Count();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) {
  Count();
  *out = __libc_memalign(alignment, n);
  return *out != nullptr || n == 0 ? 0 : ENOMEM;
}
}
#endif

namespace lagrange::testing {

AllocationCounter::AllocationCounter() : start_(t_allocations), was_enabled_(t_counting) { t_counting = true; }
AllocationCounter::~AllocationCounter() { t_counting = was_enabled_; }
std::int64_t AllocationCounter::count() const { return t_allocations - start_; }

}  // namespace lagrange::testing
