#include "tools/ballvision/calib_zhang.h"

#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <Eigen/SVD>

namespace bv::cli {
namespace {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;

using ResidualFn = std::function<void(const VectorXd&, VectorXd&)>;

// Levenberg-Marquardt with central-difference Jacobian (problems here have < 200 parameters).
double LevenbergMarquardt(const ResidualFn& f, VectorXd& x, int max_iterations, int& iterations) {
  VectorXd r;
  f(x, r);
  double cost = r.squaredNorm();
  double mu = 1e-3;
  const int n = static_cast<int>(x.size());
  MatrixXd J(r.size(), n);
  VectorXd rp, rm;
  iterations = 0;
  for (int it = 0; it < max_iterations; ++it) {
    iterations = it + 1;
    for (int k = 0; k < n; ++k) {
      const double h = 1e-6 * std::max(1.0, std::fabs(x[k]));
      VectorXd xp = x, xm = x;
      xp[k] += h;
      xm[k] -= h;
      f(xp, rp);
      f(xm, rm);
      J.col(k) = (rp - rm) / (2 * h);
    }
    const MatrixXd JtJ = J.transpose() * J;
    const VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 12; ++tries) {
      MatrixXd A = JtJ;
      for (int k = 0; k < n; ++k) A(k, k) += mu * std::max(JtJ(k, k), 1e-12);
      const VectorXd dx = A.ldlt().solve(-g);
      const VectorXd xn = x + dx;
      VectorXd rn;
      f(xn, rn);
      const double cn = rn.squaredNorm();
      if (std::isfinite(cn) && cn < cost) {
        const double rel = (cost - cn) / std::max(cost, 1e-300);
        x = xn;
        r = rn;
        cost = cn;
        mu = std::max(mu * 0.3, 1e-12);
        improved = true;
        if (rel < 1e-14 || dx.norm() < 1e-14 * (1 + x.norm())) return cost;
        break;
      }
      mu *= 10;
    }
    if (!improved) break;
  }
  return cost;
}

// Normalised DLT homography board -> image.
bool Homography(const ZhangView& v, Matrix3d& H) {
  const size_t n = v.board.size();
  auto normaliser = [](const std::vector<Vector2d>& p) {
    Vector2d c = Vector2d::Zero();
    for (const auto& q : p) c += q;
    c /= static_cast<double>(p.size());
    double d = 0;
    for (const auto& q : p) d += (q - c).norm();
    d /= static_cast<double>(p.size());
    const double s = d > 0 ? std::sqrt(2.0) / d : 1.0;
    Matrix3d T;
    T << s, 0, -s * c.x(), 0, s, -s * c.y(), 0, 0, 1;
    return T;
  };
  const Matrix3d Tb = normaliser(v.board), Ti = normaliser(v.image);
  MatrixXd A(2 * n, 9);
  for (size_t i = 0; i < n; ++i) {
    const Vector3d X = Tb * v.board[i].homogeneous();
    const Vector3d x = Ti * v.image[i].homogeneous();
    A.row(2 * i) << X.x(), X.y(), 1, 0, 0, 0, -x.x() * X.x(), -x.x() * X.y(), -x.x();
    A.row(2 * i + 1) << 0, 0, 0, X.x(), X.y(), 1, -x.y() * X.x(), -x.y() * X.y(), -x.y();
  }
  Eigen::JacobiSVD<MatrixXd> svd(A, Eigen::ComputeFullV);
  const VectorXd h = svd.matrixV().col(8);
  Matrix3d Hn;
  Hn << h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8];
  H = Ti.inverse() * Hn * Tb;
  if (std::fabs(H(2, 2)) < 1e-300) return false;
  H /= H(2, 2);
  return H.allFinite();
}

Eigen::Matrix<double, 1, 6> Vij(const Matrix3d& H, int i, int j) {
  const Vector3d hi = H.col(i), hj = H.col(j);
  Eigen::Matrix<double, 1, 6> v;
  v << hi[0] * hj[0], hi[0] * hj[1] + hi[1] * hj[0], hi[1] * hj[1], hi[2] * hj[0] + hi[0] * hj[2],
      hi[2] * hj[1] + hi[1] * hj[2], hi[2] * hj[2];
  return v;
}

Matrix3d NearestRotation(const Matrix3d& M) {
  Eigen::JacobiSVD<Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Matrix3d U = svd.matrixU();
    U.col(2) *= -1;
    R = U * svd.matrixV().transpose();
  }
  return R;
}

Vector3d RotToVec(const Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

Matrix3d VecToRot(const Vector3d& v) {
  const double a = v.norm();
  if (a < 1e-15) return Matrix3d::Identity();
  return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

Vector2d Distort(const ZhangResult& m, const Vector3d& pc) {
  const double x = pc.x() / pc.z(), y = pc.y() / pc.z();
  const double r2 = x * x + y * y;
  const double g = 1 + m.k1 * r2 + m.k2 * r2 * r2;
  const double xd = x * g, yd = y * g;
  return Vector2d(m.fx * xd + m.skew * yd + m.cx, m.fy * yd + m.cy);
}

}  // namespace

bool ZhangProject(const ZhangResult& m, const Matrix3d& R, const Vector3d& t, const Vector3d& p,
                  Vector2d& uv) {
  const Vector3d pc = R * p + t;
  if (pc.z() <= 1e-12) return false;
  uv = Distort(m, pc);
  return true;
}

namespace zhang {

bool CheckViews(const std::vector<ZhangView>& views, size_t& total, std::string& error) {
  const size_t nv = views.size();
  if (nv < 3) {
    error = "need at least 3 views of the board, got " + std::to_string(nv);
    return false;
  }
  total = 0;
  for (const auto& v : views) {
    if (v.board.size() != v.image.size() || v.board.size() < 6) {
      error = "view " + v.name + ": need at least 6 corners (got " +
              std::to_string(v.image.size()) + ")";
      return false;
    }
    for (size_t i = 0; i < v.board.size(); ++i) {
      if (!v.board[i].allFinite() || !v.image[i].allFinite()) {
        error = "view " + v.name + ": non-finite corner " + std::to_string(i);
        return false;
      }
    }
    total += v.board.size();
  }
  return true;
}

bool Homographies(const std::vector<ZhangView>& views, std::vector<Matrix3d>& Hs,
                  std::string& error) {
  Hs.resize(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    if (!Homography(views[i], Hs[i])) {
      error = "view " + views[i].name + ": homography failed (collinear corners?)";
      return false;
    }
  }
  return true;
}

// V b = 0 (b = B11 B12 B22 B13 B23 B33), B = A^-T A^-1 the image of the absolute conic.
bool ClosedFormIntrinsics(const std::vector<Matrix3d>& Hs, bool skew, Intrinsics& out,
                          std::string& error) {
  const size_t nv = Hs.size();
  const int extra = skew ? 0 : 1;
  MatrixXd V(2 * nv + extra, 6);
  for (size_t i = 0; i < nv; ++i) {
    // Scale rows for conditioning; the constraints are homogeneous.
    V.row(2 * i) = Vij(Hs[i], 0, 1);
    V.row(2 * i + 1) = Vij(Hs[i], 0, 0) - Vij(Hs[i], 1, 1);
  }
  if (!skew) {
    V.row(2 * nv) << 0, 1, 0, 0, 0, 0;
    V.row(2 * nv) *= V.topRows(2 * nv).norm();
  }
  Eigen::JacobiSVD<MatrixXd> svd(V, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  if (sv.size() >= 6 && sv[4] < 1e-9 * sv[0]) {
    error = "degenerate set of board poses (e.g. all boards parallel): intrinsics not determined";
    return false;
  }
  Eigen::VectorXd b = svd.matrixV().col(5);
  if (b[0] < 0) b = -b;
  const double B11 = b[0], B12 = b[1], B22 = b[2], B13 = b[3], B23 = b[4], B33 = b[5];
  const double den = B11 * B22 - B12 * B12;
  if (!(B11 > 0) || !(den > 0)) {
    error = "degenerate set of board poses: closed-form intrinsics not positive definite";
    return false;
  }
  const double v0 = (B12 * B13 - B11 * B23) / den;
  const double lambda = B33 - (B13 * B13 + v0 * (B12 * B13 - B11 * B23)) / B11;
  if (!(lambda / B11 > 0)) {
    error = "degenerate set of board poses: closed-form focal length imaginary";
    return false;
  }
  out.fx = std::sqrt(lambda / B11);
  out.fy = std::sqrt(lambda * B11 / den);
  out.skew = skew ? -B12 * out.fx * out.fx * out.fy / lambda : 0.0;
  out.cx = out.skew * v0 / out.fy - B13 * out.fx * out.fx / lambda;
  out.cy = v0;
  if (!std::isfinite(out.fx) || !std::isfinite(out.fy) || !std::isfinite(out.cx) ||
      !std::isfinite(out.cy)) {
    error = "closed-form intrinsics not finite";
    return false;
  }
  return true;
}

void Extrinsics(const std::vector<Matrix3d>& Hs, const Intrinsics& in, std::vector<Matrix3d>& R,
                std::vector<Vector3d>& t) {
  Matrix3d A;
  A << in.fx, in.skew, in.cx, 0, in.fy, in.cy, 0, 0, 1;
  const Matrix3d Ainv = A.inverse();
  R.resize(Hs.size());
  t.resize(Hs.size());
  for (size_t i = 0; i < Hs.size(); ++i) {
    const Vector3d h1 = Hs[i].col(0), h2 = Hs[i].col(1), h3 = Hs[i].col(2);
    double lam = 1.0 / (Ainv * h1).norm();
    Vector3d ti = lam * Ainv * h3;
    if (ti.z() < 0) {  // the board in front of the camera
      lam = -lam;
      ti = -ti;
    }
    const Vector3d r1 = lam * Ainv * h1, r2 = lam * Ainv * h2;
    Matrix3d Q;
    Q << r1, r2, r1.cross(r2);
    R[i] = NearestRotation(Q);
    t[i] = ti;
  }
}

// D [k1 k2]' = d over every corner; a non-finite coefficient (degenerate data) reads 0.
Eigen::Vector2d LinearDistortion(const std::vector<ZhangView>& views, const Intrinsics& in,
                                 const std::vector<Matrix3d>& R, const std::vector<Vector3d>& t) {
  size_t total = 0;
  for (const auto& v : views) total += v.board.size();
  MatrixXd D(2 * total, 2);
  VectorXd d(2 * total);
  size_t row = 0;
  const double alpha = in.fx, beta = in.fy, gamma = in.skew, u0 = in.cx, v0 = in.cy;
  for (size_t i = 0; i < views.size(); ++i) {
    for (size_t k = 0; k < views[i].board.size(); ++k) {
      const Vector3d pc = R[i] * Vector3d(views[i].board[k].x(), views[i].board[k].y(), 0) + t[i];
      const double x = pc.x() / pc.z(), y = pc.y() / pc.z();
      const double r2 = x * x + y * y;
      const double u = alpha * x + gamma * y + u0, v = beta * y + v0;
      D.row(row) << (u - u0) * r2, (u - u0) * r2 * r2;
      d[row++] = views[i].image[k].x() - u;
      D.row(row) << (v - v0) * r2, (v - v0) * r2 * r2;
      d[row++] = views[i].image[k].y() - v;
    }
  }
  const Eigen::Vector2d k = D.colPivHouseholderQr().solve(d);
  return {std::isfinite(k[0]) ? k[0] : 0, std::isfinite(k[1]) ? k[1] : 0};
}

// Parameters: fx fy cx cy k1 k2 [skew], then per view the rotation vector and t.
bool Refine(const std::vector<ZhangView>& views, const ZhangOptions& options, ZhangResult& m,
            std::string& error) {
  const size_t nv = views.size();
  size_t total = 0;
  for (const auto& v : views) total += v.board.size();
  const int ni = options.skew ? 7 : 6;
  VectorXd x(ni + 6 * nv);
  x[0] = m.fx;
  x[1] = m.fy;
  x[2] = m.cx;
  x[3] = m.cy;
  x[4] = m.k1;
  x[5] = m.k2;
  if (options.skew) x[6] = m.skew;
  for (size_t i = 0; i < nv; ++i) {
    x.segment<3>(ni + 6 * i) = RotToVec(m.R[i]);
    x.segment<3>(ni + 6 * i + 3) = m.t[i];
  }
  auto unpack = [&](const VectorXd& p, ZhangResult& o) {
    o.fx = p[0];
    o.fy = p[1];
    o.cx = p[2];
    o.cy = p[3];
    o.k1 = p[4];
    o.k2 = p[5];
    o.skew = options.skew ? p[6] : 0.0;
  };
  const ResidualFn f = [&](const VectorXd& p, VectorXd& r) {
    ZhangResult o;
    unpack(p, o);
    r.resize(2 * total);
    size_t row = 0;
    for (size_t i = 0; i < nv; ++i) {
      const Matrix3d R = VecToRot(p.segment<3>(ni + 6 * i));
      const Vector3d t = p.segment<3>(ni + 6 * i + 3);
      for (size_t k = 0; k < views[i].board.size(); ++k) {
        const Vector3d pc = R * Vector3d(views[i].board[k].x(), views[i].board[k].y(), 0) + t;
        const Vector2d uv = pc.z() > 1e-12 ? Distort(o, pc) : Vector2d(1e6, 1e6);
        r[row++] = uv.x() - views[i].image[k].x();
        r[row++] = uv.y() - views[i].image[k].y();
      }
    }
  };
  LevenbergMarquardt(f, x, options.max_iterations, m.iterations);
  unpack(x, m);
  VectorXd r;
  f(x, r);
  if (!r.allFinite() || !(m.fx > 0) || !(m.fy > 0)) {
    error = "refinement diverged";
    return false;
  }
  size_t row = 0;
  m.rms_per_view_px.assign(nv, 0);
  for (size_t i = 0; i < nv; ++i) {
    m.R[i] = VecToRot(x.segment<3>(ni + 6 * i));
    m.t[i] = x.segment<3>(ni + 6 * i + 3);
    const size_t n = views[i].board.size();
    m.rms_per_view_px[i] = std::sqrt(r.segment(row, 2 * n).squaredNorm() / n);
    row += 2 * n;
  }
  m.rms_px = std::sqrt(r.squaredNorm() / static_cast<double>(total));
  return true;
}

}  // namespace zhang

bool ZhangCalibrate(const std::vector<ZhangView>& views, const ZhangOptions& options,
                    ZhangResult& result, std::string& error) {
  size_t total = 0;
  std::vector<Matrix3d> Hs;
  zhang::Intrinsics in;
  if (!zhang::CheckViews(views, total, error) || !zhang::Homographies(views, Hs, error) ||
      !zhang::ClosedFormIntrinsics(Hs, options.skew, in, error)) {
    return false;
  }
  ZhangResult m;
  m.fx = m.init_fx = in.fx;
  m.fy = m.init_fy = in.fy;
  m.skew = m.init_skew = in.skew;
  m.cx = m.init_cx = in.cx;
  m.cy = m.init_cy = in.cy;
  zhang::Extrinsics(Hs, in, m.R, m.t);
  const Eigen::Vector2d k = zhang::LinearDistortion(views, in, m.R, m.t);
  m.k1 = k[0];
  m.k2 = k[1];
  if (!zhang::Refine(views, options, m, error)) return false;
  result = m;
  return true;
}

bool EstimateRigPose(const std::vector<ZhangView>& views, const ZhangResult& model,
                     const std::vector<BoardPose>& poses, Matrix3d& R_rc, Vector3d& t_rc,
                     double& rms_px, std::string& error) {
  if (poses.empty()) {
    error = "no board pose matches a calibrated view";
    return false;
  }
  // Closed form per view, averaged (chordal mean of rotations).
  Matrix3d Rsum = Matrix3d::Zero();
  Vector3d tsum = Vector3d::Zero();
  for (const auto& bp : poses) {
    const Matrix3d Rrc = bp.R * model.R[bp.view].transpose();
    Rsum += Rrc;
    tsum += bp.t - Rrc * model.t[bp.view];
  }
  R_rc = NearestRotation(Rsum);
  t_rc = tsum / static_cast<double>(poses.size());
  // Refine: p_cam = R_rc' (Rb p_board + tb - t_rc).
  size_t total = 0;
  for (const auto& bp : poses) total += views[bp.view].board.size();
  const Matrix3d R0 = R_rc;
  const ResidualFn f = [&](const VectorXd& p, VectorXd& r) {
    const Matrix3d R = VecToRot(p.head<3>()) * R0;
    const Vector3d t = p.tail<3>();
    r.resize(2 * total);
    size_t row = 0;
    for (const auto& bp : poses) {
      const ZhangView& v = views[bp.view];
      for (size_t k = 0; k < v.board.size(); ++k) {
        const Vector3d pr = bp.R * Vector3d(v.board[k].x(), v.board[k].y(), 0) + bp.t;
        const Vector3d pc = R.transpose() * (pr - t);
        const Vector2d uv = pc.z() > 1e-12 ? Distort(model, pc) : Vector2d(1e6, 1e6);
        r[row++] = uv.x() - v.image[k].x();
        r[row++] = uv.y() - v.image[k].y();
      }
    }
  };
  VectorXd x(6);
  x.head<3>().setZero();
  x.tail<3>() = t_rc;
  int it = 0;
  const double cost = LevenbergMarquardt(f, x, 100, it);
  R_rc = VecToRot(x.head<3>()) * R0;
  t_rc = x.tail<3>();
  rms_px = std::sqrt(cost / static_cast<double>(total));
  if (!R_rc.allFinite() || !t_rc.allFinite()) {
    error = "camera pose refinement diverged";
    return false;
  }
  return true;
}

}  // namespace bv::cli
