#!/usr/bin/python3
"""Checks the operation counter of the code-size peer (tools/codegen_peer/count_ops.py) on
hand-counted expressions and function bodies in both pardel's and SymPy's styles."""

import os
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools", "codegen_peer"))
import count_ops  # noqa: E402


class Expressions(unittest.TestCase):
    def test_hand_counted(self):
        cases = {
            "x": 0, "q0[3]": 0, "2.5": 0, "-x": 1, "+x": 0, "-0.5*x": 1, "x - y": 1, "-x - y": 2,
            "(1.0/2.0)*x": 1, "1.0/2.0*x": 1, "sqrt(3)*x": 1, "std::sin(a[1])*2.0": 2, "pow(x, 2)": 1,
            "(-x)*(y + z)/w": 4, "M_PI*x": 1, "atan2(y, x) + 1.0e-3": 2, "h*(x*x + y*y)*0.5": 5,
        }
        for expr, expected in cases.items():
            with self.subTest(expr=expr):
                self.assertEqual(count_ops.count_expression(expr), expected)

    def test_divisions_are_tallied_apart(self):
        tally = {}
        self.assertEqual(count_ops.count_expression("1.0/2.0*x/y + z/(1.0/3.0)", tally), 4)
        self.assertEqual(tally["div"], 2)


class Functions(unittest.TestCase):
    SOURCE = """
// a comment with = and / that must be ignored
extern "C" void f_full(double h, const double* q0, double* Ld, double* D1) {
  (void)h;
  const double pd_t0001 = std::sin(q0[0]);  // 1
  const double pd_t0002 = (q0[1] - pd_t0001)/h;  /* 2 */
  Ld[0] = pd_t0002*pd_t0002*0.5;
  D1[0] = -pd_t0002;
  D1[1] = D1[0];
  D1[1] += 1.0/h;
}
double g(double x) {
  return x*x;
}
"""

    def test_body_count_skips_casts_comments_and_copies(self):
        tally = {}
        # sin 1, (- and /) 2, (* *) 2, unary minus 1, copy 0, (+= and /) 2
        self.assertEqual(count_ops.count_function(self.SOURCE, "f_full", tally), 8)
        self.assertEqual(tally["div"], 2)
        self.assertEqual(count_ops.count_function(self.SOURCE, "g"), 1)

    def test_unknown_function_and_bad_statement_are_errors(self):
        with self.assertRaises(count_ops.CountError):
            count_ops.count_function(self.SOURCE, "missing")
        with self.assertRaises(count_ops.CountError):
            count_ops.count_function("void k() { x = (a + ; }", "k")


if __name__ == "__main__":
    unittest.main()
