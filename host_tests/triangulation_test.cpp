#include "core/triangulation/triangulation.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace bv {
namespace {

Ray MakeRay(const Eigen::Vector3f& from, const Eigen::Vector3f& through) {
  Ray r;
  r.origin = from;
  r.dir = (through - from).normalized();
  return r;
}

// Reference rig geometry: perspective camera at (0, 0.15, 0.45), omni viewpoint at (0, 0, 0.776).
const Eigen::Vector3f kPersp(0.f, 0.15f, 0.45f);
const Eigen::Vector3f kOmni(0.f, 0.f, 0.776f);

TEST(Triangulation, IntersectingRaysGiveThePointAndZeroGap) {
  for (const Eigen::Vector3f& ball :
       {Eigen::Vector3f(0.3f, 2.f, 0.11f), Eigen::Vector3f(-1.f, 4.5f, 0.41f),
        Eigen::Vector3f(0.f, 0.8f, 1.2f)}) {
    auto t = TriangulateRays(MakeRay(kPersp, ball), MakeRay(kOmni, ball));
    ASSERT_TRUE(t.ok()) << t.status().message();
    EXPECT_NEAR((t->point - ball).norm(), 0.f, 1e-4f);  // float rounding at metres
    EXPECT_NEAR(t->gap_m, 0.f, 1e-4f);
    EXPECT_NEAR(t->depth_persp_m, (ball - kPersp).norm(), 1e-4f);
    EXPECT_NEAR(t->depth_omni_m, (ball - kOmni).norm(), 1e-4f);
  }
}

TEST(Triangulation, SkewRaysGiveMidpointOfCommonPerpendicular) {
  // Persp ray along +y at x = -0.05, z = 0.5; omni ray along +x at y = 2, z = 0.6 (from x = -3):
  // common perpendicular from (-0.05, 2, 0.5) to (-0.05, 2, 0.6).
  Ray p;
  p.origin = Eigen::Vector3f(-0.05f, 0.f, 0.5f);
  p.dir = Eigen::Vector3f::UnitY();
  Ray o;
  o.origin = Eigen::Vector3f(-3.f, 2.f, 0.6f);
  o.dir = Eigen::Vector3f::UnitX();
  auto t = TriangulateRays(p, o);
  ASSERT_TRUE(t.ok());
  EXPECT_NEAR(t->point.x(), -0.05f, 1e-6f);
  EXPECT_NEAR(t->point.y(), 2.f, 1e-6f);
  EXPECT_NEAR(t->point.z(), 0.55f, 1e-6f);
  EXPECT_NEAR(t->gap_m, 0.1f, 1e-6f);
}

TEST(Triangulation, NonUnitDirectionsGiveTheSamePoint) {
  const Eigen::Vector3f ball(0.5f, 3.f, 0.3f);
  Ray p = MakeRay(kPersp, ball), o = MakeRay(kOmni, ball);
  p.dir *= 3.f;
  o.dir *= 0.2f;
  o.origin.x() += 0.01f;  // a little skew
  auto t = TriangulateRays(p, o);
  ASSERT_TRUE(t.ok());
  EXPECT_LT((t->point - ball).norm(), 0.02f);
  EXPECT_GT(t->gap_m, 0.f);
}

TEST(Triangulation, ParallelRaysAreRefusedNotDivided) {
  Ray p;
  p.origin = kPersp;
  p.dir = Eigen::Vector3f(0.f, 1.f, 0.f);
  Ray o;
  o.origin = kOmni;
  o.dir = Eigen::Vector3f(0.f, 1.f, 1e-4f).normalized();
  auto t = TriangulateRays(p, o);
  EXPECT_EQ(t.status().code(), StatusCode::kOutOfRange);
  o.dir = p.dir;
  EXPECT_EQ(TriangulateRays(p, o).status().code(), StatusCode::kOutOfRange);
  o.dir = -p.dir;  // anti-parallel too
  EXPECT_EQ(TriangulateRays(p, o).status().code(), StatusCode::kOutOfRange);
}

TEST(Triangulation, PointBehindACameraIsRefused) {
  // Rays that meet only behind the perspective camera.
  const Eigen::Vector3f behind(0.f, -2.f, 0.3f);
  Ray p = MakeRay(kPersp, behind);
  p.dir = -p.dir;
  auto t = TriangulateRays(p, MakeRay(kOmni, behind));
  EXPECT_EQ(t.status().code(), StatusCode::kNotFound);
}

TEST(Triangulation, NanOrZeroInputIsInvalidArgument) {
  Ray p = MakeRay(kPersp, Eigen::Vector3f(0, 2, 0.11f));
  Ray o = MakeRay(kOmni, Eigen::Vector3f(0, 2, 0.11f));
  Ray bad = p;
  bad.dir.x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(TriangulateRays(bad, o).status().code(), StatusCode::kInvalidArgument);
  bad = o;
  bad.dir.setZero();
  EXPECT_EQ(TriangulateRays(p, bad).status().code(), StatusCode::kInvalidArgument);
}

TEST(Triangulation, OmniGroundFallbackIntersectsPlaneAtBallRadius) {
  const Eigen::Vector3f ball(1.f, -2.f, 0.11f);
  auto p = IntersectRayWithPlaneZ(MakeRay(kOmni, ball), 0.11f);
  ASSERT_TRUE(p.ok());
  EXPECT_NEAR((*p - ball).norm(), 0.f, 1e-5f);
  // A ray pointing upwards never reaches the floor plane.
  EXPECT_EQ(IntersectRayWithPlaneZ(MakeRay(kOmni, Eigen::Vector3f(1, 1, 1)), 0.11f).status().code(),
            StatusCode::kOutOfRange);
  // Horizontal ray: refused, not divided by zero.
  Ray flat;
  flat.origin = kOmni;
  flat.dir = Eigen::Vector3f::UnitY();
  EXPECT_EQ(IntersectRayWithPlaneZ(flat, 0.11f).status().code(), StatusCode::kOutOfRange);
}

TEST(Triangulation, ApparentSizeGivesRange) {
  const Eigen::Vector3f ball(0.2f, 3.f, 0.11f);
  const Ray ray = MakeRay(kPersp, ball);
  const float range = (ball - kPersp).norm();
  const float alpha = std::asin(0.11f / range);
  auto p = PointFromApparentSize(ray, alpha, 0.11f);
  ASSERT_TRUE(p.ok());
  EXPECT_NEAR((*p - ball).norm(), 0.f, 1e-4f);
  EXPECT_EQ(PointFromApparentSize(ray, 0.f, 0.11f).status().code(), StatusCode::kOutOfRange);
  EXPECT_EQ(PointFromApparentSize(ray, std::nanf(""), 0.11f).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(Triangulation, ClosestDepthOnRay) {
  Ray r;
  r.origin = Eigen::Vector3f(0, 0, 1);
  r.dir = Eigen::Vector3f(0, 2, 0);
  EXPECT_FLOAT_EQ(ClosestDepthOnRay(r, Eigen::Vector3f(5, 3, -1)), 3.f);
}

}  // namespace
}  // namespace bv
