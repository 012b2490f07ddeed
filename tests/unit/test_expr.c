/* SPDX-License-Identifier: MIT */
/* Expressions: precedence, functions, floored modulo, errors with columns, and the limits: flat
 * chains of any length up to WG_EXPR_MAX_LENGTH characters evaluate, nesting deeper than
 * WG_EXPR_MAX_DEPTH levels is refused with a message that says so. */
#include "wgtest.h"

#include <math.h>
#include <stdlib.h>
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

/* A growing text buffer. */
typedef struct {
    char *s;
    size_t n, cap;
} Text;

static void put(Text *t, const char *piece)
{
    size_t k = strlen(piece);
    if (t->n + k + 1 > t->cap) {
        t->cap = (t->n + k + 1) * 2;
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
    memcpy(t->s + t->n, piece, k + 1);
    t->n += k;
}

/* `open` `depth` times, then `mid`, then `close` `depth` times. */
static char *nest(const char *open, const char *mid, const char *close, int depth)
{
    Text t = {0};
    put(&t, "");
    for (int i = 0; i < depth; i++) put(&t, open);
    put(&t, mid);
    for (int i = 0; i < depth; i++) put(&t, close);
    return t.s;
}

static void test_flat_chains_of_any_length(void **state)
{
    (void)state;
    /* a flat sum of 50,000 terms: as deep as a sum of two */
    Text t = {0};
    put(&t, "1");
    for (int i = 1; i < 50000; i++) put(&t, "+1");
    assert_float_equal(eval(t.s), 50000, 0);
    /* every binary level as a long chain, with variables and calls as terms */
    t.n = 0;
    put(&t, "0");
    for (int i = 0; i < 20000; i++)
        put(&t, i % 4 == 0   ? " + a * b"
                : i % 4 == 1 ? " - min(a, b, 1, 2) / 2"
                : i % 4 == 2 ? " + (a < b) * (b > a) * 1"
                             : " - 0.5 * (a == 2 && b != 2 || 0)");
    /* per 4 terms: 6 - 0.5 + 1 - 0.5 = 6 */
    assert_float_equal(eval(t.s), 5000 * 6, 1e-9);
    t.n = 0;
    put(&t, "1");
    for (int i = 0; i < 30000; i++) put(&t, " * 1 == 1 && 1 || 0");
    assert_float_equal(eval(t.s), 1, 0);
    free(t.s);
}

static void test_nesting_limit(void **state)
{
    (void)state;
    static const struct {
        const char *open, *mid, *close;
        double at_limit; /* the value with WG_EXPR_MAX_DEPTH levels */
    } kinds[] = {
        {"(", "1", ")", 1},
        {"1 + (", "1", ")", WG_EXPR_MAX_DEPTH + 1},
        {"-", "1", "", 1}, /* an even number of minus signs */
        {"abs(", "0.5 - 1.5", ")", 1},
        {"max(0, 1, 2, ", "3", ")", 3}, /* each level waits on three values */
        {"2 ^ ", "1", "", INFINITY},
        {"a > 100 ? 1 : ", "5", "", 5},
    };
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        char *src = nest(kinds[k].open, kinds[k].mid, kinds[k].close, WG_EXPR_MAX_DEPTH);
        double v = eval(src);
        if (k == 5)
            assert_true(isinf(v)); /* 2 ^ 2 ^ ... ^ 1 overflows */
        else
            assert_float_equal(v, kinds[k].at_limit, 0);
        free(src);
        src = nest(kinds[k].open, kinds[k].mid, kinds[k].close, WG_EXPR_MAX_DEPTH + 1);
        WgExprOptions opt = {resolve_ab, NULL, false};
        WgExpr *e = NULL;
        WgError err = {0};
        assert_int_equal(wg_expr_parse(src, &opt, &e, &err), WG_ERR_PARSE);
        assert_null(e);
        if (!strstr(err.message, "expression nested more than 200 levels deep (parentheses, "
                                 "function calls, unary operators"))
            fail_msg("'%.40s...': %s", src, err.message);
        free(src);
    }
    /* 2000 parentheses: refused at the first level too many, not a crash */
    char *src = nest("(", "1", "", 2000);
    parse_fails(src, WG_EXPR_MAX_DEPTH + 2, "nested more than 200 levels deep");
    free(src);
}

static void test_length_limit(void **state)
{
    (void)state;
    char *src = malloc(WG_EXPR_MAX_LENGTH + 2);
    assert_non_null(src);
    /* "1+1+...+1" of exactly the limit: accepted */
    for (int i = 0; i < WG_EXPR_MAX_LENGTH; i++) src[i] = i % 2 ? '+' : '1';
    src[WG_EXPR_MAX_LENGTH - 1] = ' ';
    src[WG_EXPR_MAX_LENGTH] = '\0';
    assert_float_equal(eval(src), WG_EXPR_MAX_LENGTH / 2, 0);
    src[WG_EXPR_MAX_LENGTH] = '1';
    src[WG_EXPR_MAX_LENGTH + 1] = '\0';
    parse_fails(src, 1, "expression too long: 1000001 characters, at most 1000000");
    free(src);
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
        cmocka_unit_test(test_flat_chains_of_any_length),
        cmocka_unit_test(test_nesting_limit),
        cmocka_unit_test(test_length_limit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
