// Helpers shared by the diagram's edits, compiler and JSON reader (not part of the public API).
#pragma once

#include <set>
#include <string>

#include "core/diagram/diagram.h"
#include "core/expr/expr.h"

namespace gb::diagram::internal {

bool IsIdentifier(const std::string& s);

// Why `signs` is not a sum block's signs (one '+' or '-' per input, at most kMaxSumInputs), or
// "" when it is.
std::string SignsProblem(const std::string& signs);
bool IsFunctionName(const std::string& s);

// "block 7" and "block 7 (lag mfv)" for messages; the Error path of a block's field.
std::string BlockLabel(const Block& b);
std::string FieldPath(const Block& b, const std::string& field);

// The names an expression field may read: parameters, and for a state block's f its ports and
// its own state, for an output block's h its ports.
std::set<std::string> AllowedNames(const BlockDiagram& d, const Block& b, const std::string& field);

// Parses `text` and checks its names against AllowedNames. The Error carries path
// FieldPath(b, field), expr_col and a message with a suggestion for a misspelt name.
Result<expr::ExprPtr> ParseField(const BlockDiagram& d, const Block& b, const std::string& field,
                                 const std::string& text);

// Whether a link from `from` to `to` closes a cycle through blocks without a state.
bool ClosesAlgebraicLoop(const BlockDiagram& d, int from_block, int to_block);

// The diagram's initial covariance as a model file writes it: "ctsm", "stationary" or the
// object of variances by state.
Json InitialCovarianceJson(const BlockDiagram& d);

// An output delay as a model file writes it: the number of samples, or {"min", "max"} for a scan.
Json DelayJson(const model::DelaySpec& d);

}  // namespace gb::diagram::internal
