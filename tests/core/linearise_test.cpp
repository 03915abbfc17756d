// The linearisation (core/model/linearise.h) of a small nonlinear model against its closed form,
// and what it refuses: hostile operating points and quantities, a model that changes with time,
// and values or standard errors that are not finite.
#include "core/model/linearise.h"

#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "core/model/model.h"
#include "core/model/nonlinear_model.h"
#include "core/project/linearised.h"
#include "core/util/json.h"

namespace gb::model {
namespace {

// A tank draining through an orifice: dh = (k u - a √h) dt, y = h + 0.1 h². At u the steady
// level is h = (k u / a)², and there A = -a / (2 √h), B = k, C = 1 + 0.2 h, D = 0.
Json LinTank() {
  return Json::parse(R"json({
    "greybench_model": 1,
    "states": ["h"], "inputs": ["u"], "outputs": ["y"],
    "parameters": {
      "k": {"value": 0.6, "lower": 0.01, "upper": 5},
      "a": {"value": 0.3, "lower": 0.01, "upper": 5},
      "s": {"value": 0.05, "fixed": true},
      "r": {"value": 0.01, "fixed": true}
    },
    "drift": {"h": "k*u - a*sqrt(h)"},
    "diffusion": {"h": "s"},
    "observation": {"y": "h + 0.1*h^2"},
    "measurement_variance": {"y": "r"},
    "initial_state": {"h": "1"}
  })json");
}

NonlinearModel CompileLinTank(const Json& j) {
  auto spec = ParseModel(j, "tank.json");
  EXPECT_TRUE(spec.ok()) << spec.error().ToString();
  auto m = NonlinearModel::Compile(*spec);
  EXPECT_TRUE(m.ok()) << m.error().ToString();
  return std::move(*m);
}

LinearisationOptions WithQuantities(const std::vector<std::string>& texts) {
  LinearisationOptions o;
  for (const auto& t : texts) {
    auto q = ParseQuantity(t);
    EXPECT_TRUE(q.ok()) << t;
    if (q) o.quantities.push_back(*q);
  }
  return o;
}

TEST(Linearise, TheTanksSteadyStateAndDerivativesAreTheClosedForms) {
  const NonlinearModel m = CompileLinTank(LinTank());
  const auto lin = Linearise(m, m.spec().Values(), {{"u", 0.5}},
                             WithQuantities({"tau=-1/A_h_h", "gain=-B_h_u/A_h_h*C_y_h"}));
  ASSERT_TRUE(lin.ok()) << lin.error().ToString();
  const double h = std::pow(0.6 * 0.5 / 0.3, 2);  // 1
  EXPECT_NEAR(lin->x(0), h, 1e-12);
  EXPECT_NEAR(lin->y(0), h + 0.1 * h * h, 1e-12);
  EXPECT_NEAR(lin->A(0, 0), -0.3 / (2 * std::sqrt(h)), 1e-12);
  EXPECT_NEAR(lin->B(0, 0), 0.6, 1e-12);
  EXPECT_NEAR(lin->C(0, 0), 1 + 0.2 * h, 1e-12);
  EXPECT_EQ(lin->D(0, 0), 0);
  EXPECT_NEAR(lin->quantities[0], 2 * std::sqrt(h) / 0.3, 1e-10);
  // The static gain dy/du = dh/du · dy/dh, dh/du = 2 k² u / a².
  EXPECT_NEAR(lin->quantities[1], 2 * 0.36 * 0.5 / 0.09 * (1 + 0.2 * h), 1e-10);
}

TEST(Linearise, RefusesAModelWhoseDriftOrObservationUsesTheTime) {
  // f = 0 holds at one time, not at all: no steady state. It used to be taken at t = 0.
  for (const auto& [key, name, text] : {std::tuple{"drift", "h", "k*u - a*sqrt(h) + 0.01*t"},
                                        std::tuple{"observation", "y", "h + 0.1*h^2 + sin(t)"}}) {
    Json j = LinTank();
    j[key][name] = text;
    const NonlinearModel m = CompileLinTank(j);
    const auto lin = Linearise(m, m.spec().Values(), {{"u", 0.5}});
    ASSERT_FALSE(lin.ok()) << text;
    EXPECT_EQ(lin.error().kind, ErrorKind::kInput);
    EXPECT_EQ(lin.error().file, "tank.json");
    EXPECT_EQ(lin.error().path, std::string(key) + "." + name);
    EXPECT_NE(lin.error().message.find("uses the time t: a model that changes with time has no "
                                       "steady state"),
              std::string::npos)
        << lin.error().message;
    EXPECT_FALSE(SteadyStateSolver::Make(m).ok());
    // A sweep's linearisations (the project's operating_points.linearised): once, not per point.
    project::LinearisedSpec spec;
    spec.point = {{"u", {"", 0.5}}};
    const project::NonlinearFit fit{m.spec().Values(), {}, {}};
    const auto sweep = project::LineariseAtPoints(m, fit, spec, {{"a", {}}, {"b", {}}});
    ASSERT_FALSE(sweep.ok());
    EXPECT_EQ(sweep.error().path, std::string(key) + "." + name);
  }
  // A parameter named t is not the time: the model is linearised as any other.
  Json j = LinTank();
  j["parameters"]["t"] = Json::parse(R"({"value": 0.1, "fixed": true})");
  j["drift"]["h"] = "k*u - a*sqrt(h) + t";
  const NonlinearModel m = CompileLinTank(j);
  const auto lin = Linearise(m, m.spec().Values(), {{"u", 0.5}});
  ASSERT_TRUE(lin.ok()) << lin.error().ToString();
  EXPECT_NEAR(lin->x(0), std::pow((0.6 * 0.5 + 0.1) / 0.3, 2), 1e-12);
}

TEST(Linearise, AQuantityThatIsNotFiniteAtThePointIsANumericalErrorNamingIt) {
  const NonlinearModel m = CompileLinTank(LinTank());
  for (const auto& [text, value] :
       {std::pair{"q=1/(u-0.5)", "inf"}, std::pair{"q=log(u-0.5)", "-inf"},
        std::pair{"q=sqrt(-u)", "nan"}}) {
    const auto lin = Linearise(m, m.spec().Values(), {{"u", 0.5}}, WithQuantities({text}));
    ASSERT_FALSE(lin.ok()) << text;
    EXPECT_EQ(lin.error().kind, ErrorKind::kNumerical);
    const std::string& msg = lin.error().message;
    EXPECT_NE(msg.find("the linearisation is not finite at this point: quantity q = "),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find(value), std::string::npos) << msg;
  }
  // A derivative that is infinite at the point: at u = 0 the tank is empty, h = 0, where
  // ∂f/∂h = -a / (2 √h) = -∞.
  const auto empty = Linearise(m, m.spec().Values(), {{"u", 0.0}});
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(empty.error().message.find("A_h_h is -inf"), std::string::npos)
      << empty.error().message;
}

TEST(Linearise, AStandardErrorThatIsNotFiniteIsANumericalErrorNamingIt) {
  // q = √(a - 0.3) is 0 at a = 0.3, but one side of its central difference is √(-step): NaN.
  const NonlinearModel m = CompileLinTank(LinTank());
  LinearisationOptions o = WithQuantities({"q=sqrt(a - 0.3)"});
  o.free = {1};  // a
  o.covariance = Eigen::MatrixXd::Constant(1, 1, 1e-4);
  const auto lin = Linearise(m, m.spec().Values(), {{"u", 0.5}}, o);
  ASSERT_FALSE(lin.ok());
  EXPECT_EQ(lin.error().kind, ErrorKind::kNumerical);
  EXPECT_NE(lin.error().message.find("the standard error of quantity q = sqrt(a - 0.3) is"),
            std::string::npos)
      << lin.error().message;
  // Without the covariance the value alone is finite and taken.
  EXPECT_TRUE(
      Linearise(m, m.spec().Values(), {{"u", 0.5}}, WithQuantities({"q=sqrt(a - 0.3)"})).ok());
}

TEST(Linearise, RefusesAQuantityNamedTwice) {
  const NonlinearModel m = CompileLinTank(LinTank());
  const auto lin =
      Linearise(m, m.spec().Values(), {{"u", 0.5}}, WithQuantities({"q=A_h_h", "q=B_h_u"}));
  ASSERT_FALSE(lin.ok());
  EXPECT_NE(lin.error().message.find("quantity q is given twice"), std::string::npos)
      << lin.error().message;
}

TEST(ParseOperatingPoint, RefusesEachKindOfHostileText) {
  const NonlinearModel m = CompileLinTank(LinTank());
  const ModelSpec& s = m.spec();
  for (const auto& [text, says] : {
           std::pair{"", "operating point: empty"},
           std::pair{"  ", "operating point: empty"},
           std::pair{"u", "'u' is not NAME=VALUE"},
           std::pair{"u=", "u: '' is not a finite number"},
           std::pair{"=1", "'=1' has no name before '='"},
           std::pair{"u=1,", "an empty item"},
           std::pair{",u=1", "an empty item"},
           std::pair{"u=1,,y=2", "an empty item"},
           std::pair{"u=nan", "u: 'nan' is not a finite number"},
           std::pair{"u=inf", "u: 'inf' is not a finite number"},
           std::pair{"u=-inf", "u: '-inf' is not a finite number"},
           std::pair{"u=1e400", "u: '1e400' is not a finite number"},
           std::pair{"u=1x", "u: '1x' is not a finite number"},
           std::pair{"u=0x10", "u: '0x10' is not a finite number"},
           std::pair{"u=++1", "u: '++1' is not a finite number"},
           std::pair{"uu=1",
                     "'uu' is not a state, input or output of the model (did you mean 'u'?)"},
           std::pair{"u=1,u=2", "'u' is given twice"},
       }) {
    const auto p = ParseOperatingPoint(text, s);
    ASSERT_FALSE(p.ok()) << "'" << text << "'";
    EXPECT_EQ(p.error().kind, ErrorKind::kInput);
    EXPECT_NE(p.error().message.find(says), std::string::npos)
        << "'" << text << "': " << p.error().message;
  }
  const auto p = ParseOperatingPoint(" u = +0.5 , y=-2e-1", s);
  ASSERT_TRUE(p.ok()) << p.error().ToString();
  ASSERT_EQ(p->size(), 2u);
  EXPECT_EQ((*p)[0], (std::pair<std::string, double>{"u", 0.5}));
  EXPECT_EQ((*p)[1], (std::pair<std::string, double>{"y", -0.2}));
}

TEST(ParseQuantity, RefusesWhatIsNotNameEqualsExpression) {
  for (const auto& [text, says] : {
           std::pair{"q", "expected NAME=EXPRESSION"},
           std::pair{"=A_h_h", "expected NAME=EXPRESSION"},
           std::pair{"1q=A_h_h", "the name '1q' is not a name"},
           std::pair{"a b=A_h_h", "the name 'a b' is not a name"},
           std::pair{"q=", "quantity q: no expression after '='"},
           std::pair{"q=1+", "quantity q:"},
       }) {
    const auto q = ParseQuantity(text);
    ASSERT_FALSE(q.ok()) << text;
    EXPECT_NE(q.error().message.find(says), std::string::npos) << text << ": " << q.error().message;
  }
  const auto q = ParseQuantity(" tau_ff = -1/A_mff_mff ");
  ASSERT_TRUE(q.ok());
  EXPECT_EQ(q->name, "tau_ff");
  EXPECT_EQ(q->text, "-1/A_mff_mff");
}

}  // namespace
}  // namespace gb::model
