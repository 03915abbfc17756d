#include "ui/format.h"

#include <cmath>
#include <cstdio>

namespace gb::ui {
namespace {

constexpr double kFullDigitsLimit = 1e9;  // below it, large numbers are printed in full
constexpr double kSmallestP = 1e-16;      // p-values below it are rounding noise

}  // namespace

std::string FormatSig(double v, int digits) {
  if (!std::isfinite(v)) return kDash;
  char buf[64];
  if (std::abs(v) >= std::pow(10.0, digits) && std::abs(v) < kFullDigitsLimit) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  }
  return buf;
}

std::string FormatSig(const std::optional<double>& v, int digits) {
  return v ? FormatSig(*v, digits) : kDash;
}

std::string FormatFixed(double v, int decimals) {
  if (!std::isfinite(v)) return kDash;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string FormatPValue(const std::optional<double>& p) {
  if (!p || !std::isfinite(*p)) return kDash;
  if (*p < kSmallestP) return "<1e-16";
  return FormatSig(*p, 3);
}

std::string DatasetLabel(const data::DatasetSpec& spec) {
  return spec.DisplayName() + (spec.role == data::Role::kValidation ? " (validation)" : "");
}

}  // namespace gb::ui
