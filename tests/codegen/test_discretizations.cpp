// Tests of the catalogue of discretizations (pardel_codegen/discretizations.hpp) against what is
// known of each family independently of it (docs/discretizations.md; the orders are measured in
// test_discretization_order.cpp): every row's name and parameters round-trip through the .lag
// reader to the canonical name and consistency order the family has, every row is in the list of
// valid names of its model orders and refused at the others, each order has one default, and the
// runtime's find_discretization gives a bare name the default the reader gives it.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"
#include "pardel_codegen/discretizations.hpp"
#include "pardel_codegen/lag_parser.hpp"

namespace {

using pardel_codegen::DiscretizationFamily;
using pardel_codegen::LagModel;
using pardel_codegen::ParameterKind;

constexpr int kMaxOrder = 4;

/** A one-coordinate model of order `order` with `line` as its discretizations line (none if empty). */
std::string lag_text(int order, const std::string& line) {
  const std::string primes(static_cast<std::size_t>(order), '\'');
  std::string text = "model m\norder " + std::to_string(order) + "\ncoords x\nL = 1/2*x" + primes + "^2 + 1/2*x^2\n";
  if (!line.empty()) text += "discretizations " + line + "\n";
  return text;
}

LagModel parse(int order, const std::string& line) { return pardel_codegen::parse_lag(lag_text(order, line), "m.lag"); }

/** The parse error of `line` for an order-`order` model ("" when it is accepted). */
std::string refusal(int order, const std::string& line) {
  try {
    parse(order, line);
  } catch (const pardel_codegen::LagError& e) {
    return e.what();
  }
  return "";
}

/** One written name, its canonical name and consistency order, as docs/discretizations.md gives them. */
struct Expected {
  std::string written, canonical;
  int consistency_order;
};

/** The names to try for `family` at `order`, with what each must give. */
std::vector<Expected> expected_names(const DiscretizationFamily& family, int order) {
  const std::string name = family.name;
  if (name == "trapezoid" && order == 1) return {{"trapezoid", "trapezoid", 2}};
  if (name == "midpoint") return {{"midpoint", "midpoint", 2}};
  if (name == "trapezoid") {
    return {{"trapezoid(alpha=1)", "trapezoid(alpha=1)", 2},
            {"trapezoid(alpha=0.5)", "trapezoid(alpha=1/2)", 2},
            {"trapezoid(alpha=-1/3)", "trapezoid(alpha=-1/3)", 2}};
  }
  if (name == "gauss2") return {{"gauss2", "gauss2", 4}};
  std::vector<Expected> out;
  for (int s = std::max(1, order); s <= order + 2; ++s) {
    const std::string canonical = name + "(s=" + std::to_string(s) + ")";
    const int consistency = name == "hermite_gauss" ? 2 * std::min(order, s) : 2 * s;
    out.push_back({canonical, canonical, consistency});
  }
  return out;
}

TEST(DiscretizationCatalogue, EveryRowRoundTripsThroughTheReader) {
  int checked = 0;
  for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
    for (int order = 1; order <= kMaxOrder; ++order) {
      if (!family.valid_for(order)) continue;
      const std::vector<Expected> names = expected_names(family, order);
      ASSERT_FALSE(names.empty()) << family.name;
      for (const Expected& e : names) {
        const LagModel m = parse(order, e.written);
        ASSERT_EQ(m.discretizations.size(), 1u) << e.written;
        EXPECT_EQ(m.discretizations[0].family, &family) << e.written << " at order " << order;
        EXPECT_EQ(m.discretizations[0].name, e.canonical) << "order " << order;
        EXPECT_EQ(m.discretizations[0].consistency_order, e.consistency_order) << e.written << " at order " << order;
        EXPECT_EQ(parse(order, m.discretizations[0].name).discretizations[0].name, e.canonical);
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 30);
}

TEST(DiscretizationCatalogue, ABareNameTakesItsDefaultOrIsRefused) {
  for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
    for (int order = 1; order <= kMaxOrder; ++order) {
      if (!family.valid_for(order) || family.parameter.kind == ParameterKind::none) continue;
      const std::string name = family.name;
      if (family.parameter.required) {
        EXPECT_NE(refusal(order, name).find(name + " needs its parameter s"), std::string::npos) << name;
        continue;
      }
      const std::string expected =
          name == "trapezoid" ? "trapezoid(alpha=1)" : name + "(s=" + std::to_string(order) + ")";
      EXPECT_EQ(parse(order, name).discretizations[0].name, expected);
    }
  }
}

TEST(DiscretizationCatalogue, TheListOfValidNamesIsTheRowsOfTheOrder) {
  for (int order = 1; order <= kMaxOrder; ++order) {
    const std::string message = refusal(order, "nonesuch");
    ASSERT_NE(message.find("unknown discretization 'nonesuch' (available for order-" + std::to_string(order)),
              std::string::npos)
        << message;
    ASSERT_NE(message.find("m.lag:5:17: error:"), std::string::npos) << message;
    // The list: from "models: " to the ')' that ends the first line, split at ", ".
    const std::size_t from = message.find("models: ") + 8, to = message.find(")\n");
    ASSERT_LT(from, to) << message;
    std::set<std::string> listed;
    for (std::size_t at = from; at < to;) {
      const std::size_t comma = std::min(message.find(", ", at), to);
      listed.insert(message.substr(at, comma - at));
      at = comma + 2;
    }
    std::set<std::string> names_of_order;
    std::size_t rows_of_order = 0;
    for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
      if (family.valid_for(order)) {
        names_of_order.insert(family.name);
        ++rows_of_order;
      }
    }
    EXPECT_EQ(listed.size(), rows_of_order) << message;
    for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
      EXPECT_EQ(listed.count(family.shown()), family.valid_for(order) ? 1u : 0u)
          << family.shown() << " at order " << order << ": " << message;
      // A name with no row for this order is refused as not available, with the same list.
      if (names_of_order.count(family.name) == 0 && family.parameter.kind == ParameterKind::none) {
        const std::string other = refusal(order, family.name);
        EXPECT_NE(other.find("'" + std::string(family.name) + "' is not available for order-" + std::to_string(order)),
                  std::string::npos)
            << other;
        EXPECT_NE(other.find(pardel_codegen::discretization_names(order)), std::string::npos) << other;
      }
    }
  }
  EXPECT_EQ(pardel_codegen::discretization_names(1),
            "trapezoid, midpoint, hermite_gauss(s=S), galerkin_gauss(s=S), galerkin_lobatto(s=S)");
  EXPECT_EQ(pardel_codegen::discretization_names(2),
            "trapezoid(alpha=A), gauss2, hermite_gauss(s=S), galerkin_gauss(s=S), galerkin_lobatto(s=S)");
  EXPECT_EQ(pardel_codegen::discretization_names(3), "hermite_gauss(s=S), galerkin_gauss(s=S), galerkin_lobatto(s=S)");
}

TEST(DiscretizationCatalogue, EachOrderHasOneDefault) {
  for (int order = 1; order <= kMaxOrder + 2; ++order) {
    int defaults = 0;
    for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
      if (family.default_for(order)) {
        ++defaults;
        EXPECT_TRUE(family.valid_for(order)) << family.name;
      }
    }
    EXPECT_EQ(defaults, 1) << "order " << order;
    const LagModel m = parse(order, "");
    ASSERT_EQ(m.discretizations.size(), 1u);
    const std::string expected = order == 1   ? "trapezoid"
                                 : order == 2 ? "trapezoid(alpha=1)"
                                              : "hermite_gauss(s=" + std::to_string(order) + ")";
    EXPECT_EQ(m.discretizations[0].name, expected);
    EXPECT_TRUE(m.discretizations[0].family->default_for(order));
  }
}

/** The runtime (built without the generator) fills in a bare name's default itself: it must give
 *  the name the reader gives it, and not take another parameter's discretization for it. */
TEST(DiscretizationCatalogue, TheRuntimeGivesABareNameTheReadersDefault) {
  for (const DiscretizationFamily& family : pardel_codegen::discretization_catalogue()) {
    for (int order = 1; order <= kMaxOrder; ++order) {
      if (!family.valid_for(order)) continue;
      const std::string bare = family.name;
      const bool takes_value = family.parameter.kind != ParameterKind::none;
      // Another discretization of the model: the same family with a value other than the default.
      const std::string with_other_value =
          takes_value ? bare + "(" + family.parameter.key + "=" + std::to_string(order + 1) + ")" : "";
      const auto other = takes_value ? parse(order, with_other_value).discretizations[0]
                                     : pardel_codegen::DiscretizationSpec{};
      EXPECT_TRUE(other.bare_name.empty()) << with_other_value << " at order " << order;
      if (family.parameter.required) {
        EXPECT_FALSE(refusal(order, bare).empty()) << bare << " at order " << order;
        continue;
      }
      const auto spec = parse(order, bare).discretizations[0];
      EXPECT_EQ(spec.bare_name, bare) << "order " << order;
      // The runtime, given the two as a generated model carries them, finds the reader's default.
      std::vector<pardel_discretization> discs(2);
      discs[0].name = takes_value ? other.name.c_str() : "nonesuch";
      discs[1].name = spec.name.c_str();
      discs[1].bare_name = spec.bare_name.c_str();
      pardel_model model{};
      model.order = order;
      model.ndiscretizations = 2;
      model.discretizations = discs.data();
      EXPECT_EQ(pardel::find_discretization(model, bare), &discs[1]) << bare << " at order " << order;
      EXPECT_EQ(pardel::find_discretization(model, spec.name), &discs[1]) << spec.name << " at order " << order;
    }
  }
}

}  // namespace
