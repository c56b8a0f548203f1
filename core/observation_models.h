// The registry of planar observation models: every way a pose observes a point
// feature, one model per kind. The chunk format, the spill frames, the native
// log reader and writer, the solver (core/problem_space.h) and every
// first-sight placement dispatch on an observation's kind through this file
// only, so adding a model is adding its header and one line in each of the
// two lists below (docs/CONTRIBUTING.md, "Add a measurement model").
//
// A model is a struct of static members (e.g. core/range_bearing_model.h):
//   kName                     "range-bearing": messages and docs
//   kNativeLogTag             its record tag in the native log ("RB")
//   kMeasurementDim           m = 1 or 2 measured values
//   kMeasurementFields[m]     their names, for messages
//   kMeasurementRule          what a valid z is, for messages ("range > 0")
//   InvalidMeasurementField(z)
//                             -1, or the index of the value that breaks the
//                             rule: a z the model cannot produce (range 0)
//   Evaluate(x, m, z, e, J_x, J_m)
//                             e = h(x, m) - z and its Jacobians with respect to
//                             (x, y, theta) and m; false when degenerate there
//   Invert(x, z)              the feature position the observation implies on
//                             its own: where it is placed at first sight
//
// The chunk record of every model is the same 61-byte observation
// (storage/chunk_format.h): z as 2 doubles and the information as 2x2. A model
// with m = 1 stores (z, 0) and diag(w, 1): its second residual is 0 with zero
// Jacobian rows, so the padding adds nothing to chi2 or to the normal
// equations whatever the second information entries are.
//
// THREAD SAFETY: pure functions. ALLOCATION: only the message strings.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include "core/bearing_model.h"
#include "core/point_observation_model.h"
#include "core/range_bearing_model.h"
#include "core/se2.h"

namespace graphslam::core {

// The kind byte of an observation: the index of its model in
// ObservationModelList below. The numbers are on disk (chunks, spill frames):
// append, never renumber.
enum class ObservationKind : uint8_t {
  kRangeBearing = 0,  // RangeBearingModel: z = (range, bearing)
  kPointXY = 1,       // PointXYModel: z = the feature in the robot frame
  kBearing = 2,       // BearingModel: z = (bearing, 0)
};

template <class... Models>
struct ModelList {
  static constexpr size_t kSize = sizeof...(Models);
};

// In ObservationKind order.
using ObservationModelList = ModelList<RangeBearingModel, PointXYModel, BearingModel>;

inline constexpr int kNumObservationKinds = static_cast<int>(ObservationModelList::kSize);

// --- dispatch ---------------------------------------------------------------

namespace internal {
template <class Visit, class... Models, size_t... I>
decltype(auto) VisitModel(size_t kind, Visit&& visit, ModelList<Models...>,
                          std::index_sequence<I...>) {
  using Result = std::common_type_t<decltype(visit(Models{}))...>;
  if constexpr (std::is_void_v<Result>) {
    (void)((kind == I ? (visit(Models{}), true) : false) || ...);
  } else {
    Result result{};
    (void)((kind == I ? (result = visit(Models{}), true) : false) || ...);
    return result;
  }
}
// The string results below for a kind outside the registry (never for a
// checked kind): not nullptr, so a message can always be built.
inline const char* OrUnknown(const char* text) { return text != nullptr ? text : "unknown"; }
}  // namespace internal

// Calls visit(Model{}) for the model of `kind`, which must be a registered
// kind (IsObservationKind); returns what it returns.
template <class Visit>
decltype(auto) VisitObservationModel(ObservationKind kind, Visit&& visit) {
  return internal::VisitModel(static_cast<size_t>(kind), std::forward<Visit>(visit),
                              ObservationModelList{},
                              std::make_index_sequence<ObservationModelList::kSize>{});
}

inline bool IsObservationKind(uint8_t kind) { return kind < kNumObservationKinds; }

// "0 to 2": the valid kind bytes, for "expected ..." messages.
inline std::string ObservationKindRange() {
  return "0 to " + std::to_string(kNumObservationKinds - 1);
}

inline const char* ObservationKindName(ObservationKind kind) {
  return internal::OrUnknown(
      VisitObservationModel(kind, [](auto model) { return decltype(model)::kName; }));
}

// e = h(x, m) - z and the Jacobians with respect to (x, y, theta) and m (any
// output may be nullptr); false when the model is degenerate at (pose, feature).
inline bool EvaluateObservation(ObservationKind kind, const Pose2& pose, const Point2& feature,
                                const Eigen::Vector2d& z, Eigen::Vector2d* residual,
                                Eigen::Matrix<double, 2, 3>* jacobian_pose,
                                Eigen::Matrix2d* jacobian_feature) {
  return VisitObservationModel(kind, [&](auto model) {
    return decltype(model)::Evaluate(pose, feature, z, residual, jacobian_pose, jacobian_feature);
  });
}

// Place a feature at first sight (paper Table 1): the position one
// observation from `pose` implies.
inline Point2 InvertObservation(ObservationKind kind, const Pose2& pose,
                                const Eigen::Vector2d& z) {
  return VisitObservationModel(
      kind, [&](auto model) { return decltype(model)::Invert(pose, z); });
}

// -1 if z may come from the model, else the index of the offending value.
inline int InvalidMeasurementField(ObservationKind kind, const Eigen::Vector2d& z) {
  return VisitObservationModel(
      kind, [&](auto model) { return decltype(model)::InvalidMeasurementField(z); });
}
inline bool IsValidMeasurement(ObservationKind kind, const Eigen::Vector2d& z) {
  return InvalidMeasurementField(kind, z) < 0;
}
inline const char* MeasurementFieldName(ObservationKind kind, int field) {
  return internal::OrUnknown(VisitObservationModel(
      kind, [&](auto model) { return decltype(model)::kMeasurementFields[field]; }));
}
inline const char* MeasurementRule(ObservationKind kind) {
  return internal::OrUnknown(VisitObservationModel(
      kind, [](auto model) { return decltype(model)::kMeasurementRule; }));
}

inline int MeasurementDim(ObservationKind kind) {
  return VisitObservationModel(kind,
                               [](auto model) { return decltype(model)::kMeasurementDim; });
}

inline const char* NativeLogTag(ObservationKind kind) {
  return internal::OrUnknown(
      VisitObservationModel(kind, [](auto model) { return decltype(model)::kNativeLogTag; }));
}

// The kind whose native log tag is `tag`; false if none.
inline bool ObservationKindOfNativeLogTag(std::string_view tag, ObservationKind* kind) {
  for (int k = 0; k < kNumObservationKinds; ++k) {
    if (tag == NativeLogTag(static_cast<ObservationKind>(k))) {
      *kind = static_cast<ObservationKind>(k);
      return true;
    }
  }
  return false;
}

}  // namespace graphslam::core
