#pragma once
// Error handling for the whole project: no exceptions, every failure is a value.
#include <cstdint>
#include <type_traits>
#include <utility>

namespace bv {

enum class StatusCode : uint8_t {
  kOk = 0,
  kInvalidArgument = 1,    // malformed input (bad size, NaN, bad field)
  kOutOfRange = 2,         // value outside the modelled domain
  kResourceExhausted = 3,  // a fixed capacity was reached; nothing was truncated silently
  kDataLoss = 4,           // checksum / CRC mismatch, truncated blob
  kUnavailable = 5,        // no data right now (no frame, UART full); try again later
  kFailedPrecondition = 6, // call order / state wrong (not initialised)
  kNotFound = 7,
  kDeadlineExceeded = 8,
  kUnimplemented = 9,
  kInternal = 10,
};

const char* StatusCodeName(StatusCode code);

/// A status code plus a static message naming what went wrong. The message must point to
/// storage with static lifetime (a string literal), so Status stays trivially copyable.
class [[nodiscard]] Status {
 public:
  constexpr Status() = default;
  constexpr Status(StatusCode code, const char* message) : code_(code), message_(message) {}
  static constexpr Status Ok() { return Status(); }

  constexpr bool ok() const { return code_ == StatusCode::kOk; }
  constexpr StatusCode code() const { return code_; }
  constexpr const char* message() const { return message_ ? message_ : ""; }
  constexpr void IgnoreError() const {}

 private:
  StatusCode code_ = StatusCode::kOk;
  const char* message_ = nullptr;
};

/// Value or error. T must be default constructible (fixed-size types only on the device).
template <typename T>
class [[nodiscard]] Result {
 public:
  constexpr Result(const T& value) : value_(value) {}  // NOLINT(google-explicit-constructor)
  constexpr Result(T&& value) : value_(std::move(value)) {}  // NOLINT
  constexpr Result(Status status) : status_(status) {}  // NOLINT(google-explicit-constructor)

  constexpr bool ok() const { return status_.ok(); }
  constexpr Status status() const { return status_; }
  constexpr const T& value() const& { return value_; }
  constexpr T& value() & { return value_; }
  constexpr const T& operator*() const { return value_; }
  constexpr const T* operator->() const { return &value_; }

 private:
  Status status_;
  T value_{};
};

}  // namespace bv

#define BV_CONCAT_INNER(a, b) a##b
#define BV_CONCAT(a, b) BV_CONCAT_INNER(a, b)

/// Returns the status from the enclosing function if `expr` failed.
#define BV_TRY(expr)                              \
  do {                                            \
    const ::bv::Status bv_try_status_ = (expr);   \
    if (!bv_try_status_.ok()) return bv_try_status_; \
  } while (0)

/// Assigns the value of a Result to `lhs` or returns its status.
#define BV_TRY_ASSIGN(lhs, expr) BV_TRY_ASSIGN_IMPL(BV_CONCAT(bv_result_, __LINE__), lhs, expr)
#define BV_TRY_ASSIGN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                       \
  if (!tmp.ok()) return tmp.status();      \
  lhs = std::move(tmp.value())
