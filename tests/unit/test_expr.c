/* SPDX-License-Identifier: MIT */
/* Expressions: precedence, functions, floored modulo, errors with columns. */
#include "wgtest.h"

#include <math.h>
#include <string.h>

static bool resolve_ab(void *user, const char *name, size_t len, int *slot)
{
    (void)user;
    static const char *const names[] = {"a", "b", "$time", "water_level"};
    for (int i = 0; i < 4; i++)
        if (strlen(names[i]) == len && !strncmp(names[i], name, len)) {
            *slot = i;
            return true;
        }
    return false;
}

static double eval(const char *src)
{
    WgExprOptions opt = {resolve_ab, NULL, false};
    WgExpr *e = NULL;
    WgError err = {0};
    if (wg_expr_parse(src, &opt, &e, &err))
        fail_msg("parse '%s': %s (column %d)", src, err.message, err.column);
    double slots[4] = {2, 3, 0.5, 0.4};
    double v = wg_expr_eval(e, slots);
    wg_expr_free(e);
    return v;
}

static void parse_fails(const char *src, int column, const char *needle)
{
    WgExprOptions opt = {resolve_ab, NULL, false};
    WgExpr *e = NULL;
    WgError err = {0};
    int rc = wg_expr_parse(src, &opt, &e, &err);
    if (rc == WG_OK) fail_msg("'%s' should not parse", src);
    assert_null(e);
    assert_int_equal(rc, WG_ERR_PARSE);
    if (err.column != column)
        fail_msg("'%s': column %d, expected %d (%s)", src, err.column, column, err.message);
    if (!strstr(err.message, needle))
        fail_msg("'%s': message '%s' lacks '%s'", src, err.message, needle);
}

static void test_arithmetic(void **state)
{
    (void)state;
    assert_float_equal(eval("1 + 2 * 3"), 7, 0);
    assert_float_equal(eval("(1 + 2) * 3"), 9, 0);
    assert_float_equal(eval("-a ^ 2"), -4, 0);     /* unary minus binds looser than ^ */
    assert_float_equal(eval("2 ^ 3 ^ 2"), 512, 0); /* right-associative */
    assert_float_equal(eval("2 + water_level * 8"), 5.2, 1e-12);
    assert_float_equal(eval("a / b"), 2.0 / 3.0, 0);
    assert_float_equal(eval("$time * 2"), 1, 0);
    assert_float_equal(eval(" 1.5e2 "), 150, 0);
    assert_float_equal(eval("--a"), 2, 0);
}

static void test_modulo_is_floored(void **state)
{
    (void)state;
    assert_float_equal(eval("7 % 3"), 1, 0);
    assert_float_equal(eval("-7 % 3"), 2, 0);
    assert_float_equal(eval("7 % -3"), -2, 0);
    assert_float_equal(eval("mod(-0.25, 1)"), 0.75, 0);
    assert_float_equal(eval("fract(-1.25)"), 0.75, 0);
}

static void test_logic_and_conditionals(void **state)
{
    (void)state;
    assert_float_equal(eval("a < b"), 1, 0);
    assert_float_equal(eval("a >= b"), 0, 0);
    assert_float_equal(eval("a == 2 && b != 2"), 1, 0);
    assert_float_equal(eval("a > 5 || !(b > 5)"), 1, 0);
    assert_float_equal(eval("a > b ? 10 : 20"), 20, 0);
    assert_float_equal(eval("a < b ? a < 1 ? 1 : 2 : 3"), 2, 0);
    assert_float_equal(eval("1 < 2 == 1"), 1, 0);
}

static void test_functions(void **state)
{
    (void)state;
    assert_float_equal(eval("abs(-3)"), 3, 0);
    assert_float_equal(eval("min(4, 2, 3)"), 2, 0);
    assert_float_equal(eval("max(4, 2, 7, 1)"), 7, 0);
    assert_float_equal(eval("clamp(5, 0, 1)"), 1, 0);
    assert_float_equal(eval("lerp(2, 4, 0.25)"), 2.5, 0);
    assert_float_equal(eval("mix(2, 4, 0.5)"), 3, 0);
    assert_float_equal(eval("smoothstep(0, 1, 0.5)"), 0.5, 0);
    assert_float_equal(eval("smoothstep(0, 1, -1)"), 0, 0);
    assert_float_equal(eval("smoothstep(1, 1, 1)"), 1, 0); /* degenerate edge: a step */
    assert_float_equal(eval("step(0.5, 0.4)"), 0, 0);
    assert_float_equal(eval("step(0.5, 0.5)"), 1, 0);
    assert_float_equal(eval("floor(-1.5) + ceil(1.2)"), 0, 0);
    assert_float_equal(eval("sqrt(16) + pow(2, 10)"), 1028, 0);
    assert_float_equal(eval("exp(0) + log(1)"), 1, 0);
    assert_float_equal(eval("sin(0) + cos(0) + tan(0)"), 1, 0);
    assert_float_equal(eval("atan2(1, 1)"), M_PI / 4, 1e-15);
}

static void test_ieee_division(void **state)
{
    (void)state;
    assert_true(isinf(eval("1 / 0")));
    assert_true(isnan(eval("0 / 0")));
    assert_true(isnan(eval("sqrt(-1)")));
}

static void test_errors_have_columns(void **state)
{
    (void)state;
    parse_fails("1 + wter_level", 5, "unknown name 'wter_level'");
    parse_fails("2 * (a + 1", 11, "expected ')'");
    parse_fails("clamp(a, 0)", 1, "'clamp' takes 3 arguments, got 2");
    parse_fails("min(a)", 1, "'min' takes 2 to 4 arguments, got 1");
    parse_fails("foo(1)", 1, "unknown function 'foo'");
    parse_fails("a +", 4, "unexpected end");
    parse_fails("a b", 3, "unexpected 'b'");
    parse_fails("", 1, "empty expression");
    parse_fails("sample(a, 0, 0)", 1, "only available in the pixel node");
    parse_fails("3x", 2, "unexpected letter after a number");
    parse_fails("0x10", 2, "unexpected letter after a number"); /* decimal only, as values */
    parse_fails("2 * 1e999", 5, "number too large");
    parse_fails("a ? 1", 6, "expected ':'");
    parse_fails("sin", 1, "is a function");
}

static void test_deep_nesting_is_an_error_not_a_crash(void **state)
{
    (void)state;
    char src[5000];
    memset(src, '(', 2000);
    strcpy(src + 2000, "1");
    WgExprOptions opt = {resolve_ab, NULL, false};
    WgExpr *e = NULL;
    WgError err = {0};
    assert_int_equal(wg_expr_parse(src, &opt, &e, &err), WG_ERR_PARSE);
    assert_non_null(strstr(err.message, "nested too deeply"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_arithmetic),
        cmocka_unit_test(test_modulo_is_floored),
        cmocka_unit_test(test_logic_and_conditionals),
        cmocka_unit_test(test_functions),
        cmocka_unit_test(test_ieee_division),
        cmocka_unit_test(test_errors_have_columns),
        cmocka_unit_test(test_deep_nesting_is_an_error_not_a_crash),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
