// Pipeline::Process must never allocate: global operator new/new[] (and, outside ASan, malloc &
// co. through glibc's __libc_* entry points) are replaced by counting versions, and full frame
// pairs run through the pipeline after Init while counting.
#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include <gtest/gtest.h>

#include "core/color_lut/color_lut.h"
#include "core/pipeline.h"
#include "tools/ballvision/demo_scene.h"
#include "tools/ballvision/run_common.h"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_news{0};
std::atomic<long> g_mallocs{0};
}  // namespace

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define BV_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define BV_ASAN 1
#endif

#if !defined(BV_ASAN) && defined(__GLIBC__)
#define BV_COUNT_MALLOC 1
extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void __libc_free(void*);
void* malloc(size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_malloc(n);
}
void* calloc(size_t n, size_t s) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_calloc(n, s);
}
void* realloc(void* p, size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
}
#endif

// Out of line so GCC does not pair the inlined free() with `new` (-Wmismatched-new-delete).
[[gnu::noinline]] void* CountedAllocate(size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void CountedRelease(void* p) noexcept { std::free(p); }

void* operator new(size_t n) { return CountedAllocate(n); }
void* operator new[](size_t n) { return CountedAllocate(n); }
void operator delete(void* p) noexcept { CountedRelease(p); }
void operator delete[](void* p) noexcept { CountedRelease(p); }
void operator delete(void* p, size_t) noexcept { CountedRelease(p); }
void operator delete[](void* p, size_t) noexcept { CountedRelease(p); }

namespace bv {
namespace {

TEST(NoAlloc, CountersWork) {
  // The counters must see an allocation, or the real test proves nothing.
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  auto* v = new std::vector<int>(100);
  g_counting = false;
  delete v;
  EXPECT_GE(g_news.load(), 1);
#ifdef BV_COUNT_MALLOC
  g_counting = true;
  void* p = std::malloc(64);
  g_counting = false;
  std::free(p);
  EXPECT_GE(g_mallocs.load(), 1);
#endif
}

TEST(NoAlloc, ProcessNeverAllocatesAfterInit) {
  const RigCalibration cal = cli::MakeDemoCalibration();
  auto lut = std::make_unique<ColorLut>();
  cli::FillBuiltInLut(*lut);
  auto pipeline = std::make_unique<OwnedPipeline>();
  ASSERT_TRUE(pipeline->Init(cal, *lut, PipelineConfig{}).ok());
  const cli::DemoRenderer renderer(cal);
  // Render every frame before counting (the renderer is a host tool and allocates).
  constexpr int kFrames = 40;
  std::vector<std::vector<uint8_t>> omni(kFrames), persp(kFrames);
  for (int k = 0; k < kFrames; ++k) {
    renderer.Render(cli::DemoLob(k / 30.0, 0.7).p, static_cast<uint32_t>(k + 1), omni[k], persp[k]);
  }
  int found = 0;
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  for (int k = 0; k < kFrames; ++k) {
    FrameInput in;
    in.t_us = static_cast<uint64_t>(k) * 33333;
    // Both cameras, then the single-camera paths and a frame with no camera.
    if (k % 7 != 3 && k % 11 != 5) in.omni = MakeYuyvImage(omni[k].data(), 640, 480);
    if (k % 7 != 4 && k % 11 != 5) in.persp = MakeYuyvImage(persp[k].data(), 640, 480);
    BallState s;
    const Status st = pipeline->Process(in, s);
    if (!st.ok()) break;
    found += s.found;
  }
  g_counting = false;
  EXPECT_EQ(g_news.load(), 0) << "operator new called inside Pipeline::Process";
#ifdef BV_COUNT_MALLOC
  EXPECT_EQ(g_mallocs.load(), 0) << "malloc called inside Pipeline::Process";
#endif
  EXPECT_GT(found, kFrames / 2);  // the frames really went through the whole pipeline
}

}  // namespace
}  // namespace bv
