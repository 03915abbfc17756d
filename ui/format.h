// Numbers as the estimate and parameters views print them, and datasets as the views name them. A
// value that is absent or not finite is printed as kDash, never as "nan" or "inf".
#pragma once

#include <optional>
#include <string>

#include "core/data/import.h"

namespace gb::ui {

inline constexpr const char* kDash = "\xE2\x80\x93";  // "–"

// `digits` significant digits without trailing zeros ("0.07395", "1.2e-05"); whole numbers up
// to 1e9 are printed in full rather than in exponent form ("1603", not "1.6e+03").
std::string FormatSig(double v, int digits);
std::string FormatSig(const std::optional<double>& v, int digits);
// A fixed number of decimals ("29643.569").
std::string FormatFixed(double v, int decimals);
// A two-sided p-value: "<1e-16" below what doubles resolve, else 3 significant digits.
std::string FormatPValue(const std::optional<double>& p);

// A dataset as the views name it: its name (or file name), "(validation)" for a record that is
// not fitted.
std::string DatasetLabel(const data::DatasetSpec& spec);

}  // namespace gb::ui
