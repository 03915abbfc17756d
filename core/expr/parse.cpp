// Parse: a recursive-descent parser over the grammar in expr.h, lexing one token ahead.
//
// Parse functions return nullptr after recording the first error, and every caller passes the
// nullptr on; so the error reported is the first one met in reading order.
#include <algorithm>
#include <charconv>
#include <optional>
#include <string>
#include <utility>

#include "core/expr/expr.h"
#include "core/expr/internal.h"

namespace gb::expr {
namespace {

// Deeper nesting (parentheses, unary minus chains, a^b^c...) is refused, which bounds the
// recursion of the parser.
constexpr int kMaxNesting = 256;
// A tree taller than kMaxHeight (expr.h) is refused. Nesting alone does not bound the height:
// a+b+c+... is a chain one level per operator, and every function that walks the tree (printing,
// simplifying, differentiating, even freeing it) recurses once per level, so a long enough sum
// in a file would overflow the stack.

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsNameStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsNameChar(char c) { return IsNameStart(c) || IsDigit(c); }

enum class Tok { kEnd, kNumber, kName, kPunct };

struct Token {
  Tok kind = Tok::kEnd;
  std::string_view text;
  double value = 0.0;  // kNumber
  int column = 1;      // 1-based; one past the end for kEnd
};

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  Result<ExprPtr> Run() {
    if (!Advance()) return *error_;
    if (tok_.kind == Tok::kEnd) return Failure(1, "empty expression");
    ExprPtr e = ParseSum();
    if (e && tok_.kind != Tok::kEnd) {
      Fail(tok_.column, Is(')') ? "unmatched ')'" : "unexpected " + Quote(tok_));
      e = nullptr;
    }
    if (!e) return *error_;
    return e;
  }

 private:
  // ----- Lexer -------------------------------------------------------------------------------

  char At(std::size_t i) const { return i < text_.size() ? text_[i] : '\0'; }
  int Column(std::size_t i) const { return static_cast<int>(i) + 1; }

  // Reads the next token into tok_; false after recording an error.
  bool Advance() {
    while (At(pos_) == ' ' || At(pos_) == '\t') ++pos_;
    const std::size_t start = pos_;
    tok_ = Token{};
    tok_.column = Column(start);
    if (start >= text_.size()) return true;
    const char c = text_[start];
    if (IsDigit(c) || (c == '.' && IsDigit(At(start + 1)))) return LexNumber();
    if (IsNameStart(c)) {
      while (IsNameChar(At(pos_))) ++pos_;
      tok_.kind = Tok::kName;
      tok_.text = text_.substr(start, pos_ - start);
      return true;
    }
    constexpr std::string_view kPunct = "+-*/^(),";
    if (kPunct.find(c) != std::string_view::npos) {
      ++pos_;
      tok_.kind = Tok::kPunct;
      tok_.text = text_.substr(start, 1);
      return true;
    }
    Fail(tok_.column, "unexpected character " + DescribeChar(start));
    return false;
  }

  // NUMBER := digits ['.' digits] [('e'|'E') ['+'|'-'] digits], also '.5' and '5.'.
  bool LexNumber() {
    const std::size_t start = pos_;
    while (IsDigit(At(pos_))) ++pos_;
    if (At(pos_) == '.') {
      ++pos_;
      while (IsDigit(At(pos_))) ++pos_;
    }
    if (At(pos_) == 'e' || At(pos_) == 'E') {
      ++pos_;
      if (At(pos_) == '+' || At(pos_) == '-') ++pos_;
      if (!IsDigit(At(pos_))) {
        const std::string seen(text_.substr(start, pos_ - start));
        Fail(Column(pos_), "malformed number '" + seen + std::string(RunFrom(pos_)) +
                               "': the exponent has no digits");
        return false;
      }
      while (IsDigit(At(pos_))) ++pos_;
    }
    const std::string_view text = text_.substr(start, pos_ - start);
    if (At(pos_) == '.' || IsDigit(At(pos_))) {
      Fail(Column(pos_), "malformed number '" + std::string(RunFrom(start)) + "'");
      return false;
    }
    if (IsNameStart(At(pos_))) {
      std::size_t end = pos_;
      while (IsNameChar(At(end))) ++end;
      Fail(Column(pos_), "missing operator between '" + std::string(text) + "' and '" +
                             std::string(text_.substr(pos_, end - pos_)) + "'");
      return false;
    }
    double value = 0.0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), value);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size()) {
      Fail(Column(start), "number '" + std::string(text) + "' is out of range");
      return false;
    }
    tok_.kind = Tok::kNumber;
    tok_.text = text;
    tok_.value = value;
    return true;
  }

  // The characters that look like part of a number starting at `start` ("1.2.3", "1e").
  std::string_view RunFrom(std::size_t start) const {
    std::size_t end = start;
    while (IsNameChar(At(end)) || At(end) == '.') ++end;
    return text_.substr(start, end - start);
  }

  std::string DescribeChar(std::size_t i) const {
    const unsigned char c = static_cast<unsigned char>(text_[i]);
    if (c < 0x20 || c == 0x7f) return "(control code " + std::to_string(c) + ")";
    std::size_t end = i + 1;  // a whole UTF-8 sequence, so the message shows the character
    if (c >= 0x80) {
      while (end < text_.size() && (static_cast<unsigned char>(text_[end]) & 0xC0) == 0x80) ++end;
    }
    return "'" + std::string(text_.substr(i, end - i)) + "'";
  }

  static std::string Quote(const Token& t) { return "'" + std::string(t.text) + "'"; }

  bool Is(char c) const { return tok_.kind == Tok::kPunct && tok_.text[0] == c; }

  // ----- Errors ------------------------------------------------------------------------------

  void Fail(int column, std::string message) {
    if (error_) return;  // keep the first
    Error e = InputError(std::move(message));
    e.expr_col = column;
    error_ = std::move(e);
  }

  Error Failure(int column, std::string message) {
    Fail(column, std::move(message));
    return *error_;
  }

  // An error at the current token: what was found instead of an operand.
  ExprPtr FailUnexpected() {
    if (tok_.kind == Tok::kEnd)
      Fail(tok_.column, "unexpected end of expression");
    else if (Is(')'))
      Fail(tok_.column, "unexpected ')'");
    else
      Fail(tok_.column, "unexpected " + Quote(tok_));
    return nullptr;
  }

  // ----- Grammar -----------------------------------------------------------------------------

  // Every parse function leaves the height of the tree it returns in height_ (a leaf is 1).
  // Records the height of a node over children of heights `a` and `b`; false (after recording
  // the error at `column`) when it exceeds kMaxHeight.
  bool SetHeight(int a, int b, int column) {
    height_ = std::max(a, b) + 1;
    if (height_ <= kMaxHeight) return true;
    Fail(column, "expression too long: more than " + std::to_string(kMaxHeight) +
                     " levels of operations (group long sums or products in parentheses)");
    return false;
  }

  // sum := product (('+' | '-') product)*
  ExprPtr ParseSum() {
    ExprPtr left = ParseProduct();
    while (left && (Is('+') || Is('-'))) {
      const Op op = Is('+') ? Op::kAdd : Op::kSub;
      const int column = tok_.column;
      const int left_height = height_;
      if (!Advance()) return nullptr;
      ExprPtr right = ParseProduct();
      if (!right || !SetHeight(left_height, height_, column)) return nullptr;
      left = internal::MakeNode(op, {left, right}, left->column);
    }
    return left;
  }

  // product := unary (('*' | '/') unary)*
  ExprPtr ParseProduct() {
    ExprPtr left = ParseUnary();
    while (left && (Is('*') || Is('/'))) {
      const Op op = Is('*') ? Op::kMul : Op::kDiv;
      const int column = tok_.column;
      const int left_height = height_;
      if (!Advance()) return nullptr;
      ExprPtr right = ParseUnary();
      if (!right || !SetHeight(left_height, height_, column)) return nullptr;
      left = internal::MakeNode(op, {left, right}, left->column);
    }
    return left;
  }

  // unary := '-' unary | '+' unary | power. Every nested construct passes through here, so this
  // is where nesting is counted.
  ExprPtr ParseUnary() {
    if (depth_ >= kMaxNesting) {
      Fail(tok_.column,
           "expression nested too deeply (more than " + std::to_string(kMaxNesting) + " levels)");
      return nullptr;
    }
    ++depth_;
    ExprPtr e;
    if (Is('-') || Is('+')) {
      const bool minus = Is('-');
      const int column = tok_.column;
      if (Advance()) e = ParseUnary();
      if (e && minus) {
        if (!SetHeight(height_, 0, column)) return nullptr;
        e = internal::MakeNode(Op::kNeg, {e}, column);
      }
    } else {
      e = ParsePower();
    }
    --depth_;
    return e;
  }

  // power := atom ('^' unary)?
  ExprPtr ParsePower() {
    ExprPtr base = ParseAtom();
    if (!base || !Is('^')) return base;
    const int column = tok_.column;
    const int base_height = height_;
    if (!Advance()) return nullptr;
    ExprPtr exponent = ParseUnary();
    if (!exponent || !SetHeight(base_height, height_, column)) return nullptr;
    return internal::MakeNode(Op::kPow, {base, exponent}, base->column);
  }

  // atom := NUMBER | NAME | NAME '(' expr (',' expr)* ')' | '(' expr ')'
  ExprPtr ParseAtom() {
    const Token t = tok_;
    if (t.kind == Tok::kNumber) {
      if (!Advance()) return nullptr;
      height_ = 1;
      return Constant(t.value, t.column);
    }
    if (t.kind == Tok::kName) {
      if (!Advance()) return nullptr;
      if (Is('(')) return ParseCall(t);
      height_ = 1;
      return Variable(std::string(t.text), t.column);
    }
    if (!Is('(')) return FailUnexpected();
    if (!Advance()) return nullptr;
    ExprPtr inner = ParseSum();
    if (!inner || !ExpectClosing(t.column)) return nullptr;
    return inner;
  }

  // After the name of a function; the current token is '('.
  ExprPtr ParseCall(const Token& name) {
    const std::optional<Func> f = internal::FindParseableFunc(name.text);
    if (!f) {
      Fail(name.column, "unknown function " + Quote(name));
      return nullptr;
    }
    const int arity = internal::Info(*f).arity;
    const std::string arity_message =
        Quote(name) + " takes " + std::to_string(arity) + (arity == 1 ? " argument" : " arguments");
    const int open_column = tok_.column;
    if (!Advance()) return nullptr;
    if (Is(')')) {
      Fail(name.column, arity_message);
      return nullptr;
    }
    std::vector<ExprPtr> args;
    int args_height = 0;
    for (;;) {
      ExprPtr arg = ParseSum();
      if (!arg) return nullptr;
      args_height = std::max(args_height, height_);
      args.push_back(std::move(arg));
      if (!Is(',')) break;
      if (!Advance()) return nullptr;
    }
    if (!ExpectClosing(open_column)) return nullptr;
    if (static_cast<int>(args.size()) != arity) {
      Fail(name.column, arity_message);
      return nullptr;
    }
    if (!SetHeight(args_height, 0, name.column)) return nullptr;
    return internal::MakeRawCall(*f, std::move(args), name.column);
  }

  // Consumes the ')' matching the '(' at `open_column`.
  bool ExpectClosing(int open_column) {
    if (!Is(')')) {
      Fail(tok_.column, "expected ')' to close '(' at column " + std::to_string(open_column));
      return false;
    }
    return Advance();
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  Token tok_;
  int depth_ = 0;
  int height_ = 0;
  std::optional<Error> error_;
};

}  // namespace

Result<ExprPtr> Parse(std::string_view text) { return Parser(text).Run(); }

}  // namespace gb::expr
