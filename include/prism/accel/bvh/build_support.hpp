// prism/accel/bvh/build_support.hpp — what the BVH builds (and the mesh
// layers' packing) share: memory (huge pages, vectors whose new elements the
// threads that fill them are the first to touch) and threads (items handed
// out one at a time, or contiguous chunks, on up to a given number).
#pragma once
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <thread>
#include <type_traits>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace prism {
namespace detail {

// Asks the OS to back a large buffer about to be written with huge pages
// (Linux transparent huge pages in "madvise" mode): building a BVH writes some
// hundred megabytes, and faulting them in 4 KiB at a time is a large share of
// the build time. A hint only; elsewhere, or for small buffers, nothing.
inline void advise_huge_pages([[maybe_unused]] const void* p, [[maybe_unused]] size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t huge = uintptr_t(2) << 20;
  uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + huge - 1) & ~(huge - 1);
  uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(huge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#endif
}
// std::allocator, except that a vector's resize() default-initialises the
// elements it adds instead of value-initialising them: for a trivial T they
// are left unwritten, so that their pages are first touched (and zeroed by
// the kernel) by the threads that fill them, not zeroed once more by the
// calling thread first. For arrays that the build writes whole in parallel
// (wide nodes, triangle packets): zeroing the 1M-triangle mesh's 40 MB of
// packets on one thread took 2-80 ms of a 2-thread build of about 0.2 s.
// (Construction with arguments falls through std::allocator_traits to
// std::construct_at, and rebinding to the template's first argument.)
template <class T>
struct fill_later_allocator : std::allocator<T> {
  fill_later_allocator() = default;
  template <class U>
  fill_later_allocator(const fill_later_allocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
};
template <class T>
using fill_later_vector = std::vector<T, fill_later_allocator<T>>;

template <class T, class A>
void reserve_huge(std::vector<T, A>& v, size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}
// An array of n default-initialised T (trivial T: not written, so the pages
// are first touched by the threads that fill them), huge pages advised.
template <class T>
std::unique_ptr<T[]> make_huge_array(size_t n) {
  static_assert(std::is_trivially_default_constructible_v<T>);
  std::unique_ptr<T[]> a(new T[n]);
  advise_huge_pages(a.get(), n * sizeof(T));
  return a;
}

// Threads for a build: 0 means all hardware threads.
inline int build_threads(int requested) {
  return requested > 0 ? requested : int(std::max(1u, std::thread::hardware_concurrency()));
}
// Runs fn(i) for every i in [0, n) on up to `threads` threads (the calling
// thread among them), handing out items one at a time so that uneven items
// keep every thread busy.
template <class F>
void parallel_items(size_t n, int threads, F&& fn) {
  size_t t = std::min(n, size_t(std::max(1, threads)));
  if (t <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t i = next.fetch_add(1); i < n; i = next.fetch_add(1)) fn(i);
  };
  std::vector<std::thread> pool;
  for (size_t c = 1; c < t; ++c) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}
// How many contiguous chunks parallel_chunks should split n items into.
inline int parallel_chunk_count(size_t n, int threads) { return n < 64 * 1024 ? 1 : std::max(1, threads); }
// Runs fn(begin, end, chunk) on `chunks` contiguous ranges of [0, n), one
// thread per chunk (the calling thread takes the first).
template <class F>
void parallel_chunks(size_t n, int chunks, F&& fn) {
  if (chunks <= 1) {
    fn(size_t(0), n, 0);
    return;
  }
  std::vector<std::thread> pool;
  for (int c = 1; c < chunks; ++c)
    pool.emplace_back([&, c] { fn(n * size_t(c) / size_t(chunks), n * size_t(c + 1) / size_t(chunks), c); });
  fn(size_t(0), n / size_t(chunks), 0);
  for (auto& t : pool) t.join();
}

}  // namespace detail
}  // namespace prism
