/* SPDX-License-Identifier: MIT */
/* Mutation fuzzing of loading, checking and rendering. A few valid graphs written below (every
 * parameter type, inputs with and without defaults, expressions, every kind of node size, a
 * subgraph read from disk with a forwarded enum, every built-in node family, image files, values
 * near the float limits, several outputs) are mutated by a deterministic xorshift stream: byte
 * flips, deleted, duplicated and swapped spans, inserted XML and expression tokens, truncation,
 * extreme attribute values, random expressions, duplicated <node> elements, ids swapped and
 * references redirected into cycles, changed node types, added attributes, document types with
 * entities. Each mutant is loaded from an exact-size buffer (some run as a subgraph read from
 * its file); if it loads it is checked at a tiny size, and if that passes it is rendered with
 * one thread (some also with two, which must give identical bits; some with a budget of a few
 * images, or through a disk cache). Some calls pass no WgError. Every outcome must be clean:
 * no crash, no sanitizer report, no hang, every failure a negative status equal to err.code
 * with a message and a line >= 0, and only finite output values unless a pixel node may set
 * allow_nonfinite.
 *
 * The stream is fixed so runs are reproducible; WGTEST_FUZZ_SEED and WGTEST_FUZZ_COUNT explore
 * further (WGTEST_FUZZ_KEEP_GOING=1 reports every bad mutant instead of stopping at the first,
 * WGTEST_FUZZ_VERBOSE=1 prints every failure, WGTEST_FUZZ_DUMP=file keeps the mutant being run
 * there, for crashes). Every bug found this way is pinned below as a named regression graph that
 * runs whatever the stream does. */
#include "wgtest.h"

#include "internal.h"

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define DEFAULT_SEED 0x5eed2024u
#define DEFAULT_COUNT 2000
#define MAX_MUTANT (96 * 1024)
/* renders whose instances hold more pixels than this are only checked (a mutated size="16384"
 * is valid but would take a gigabyte) */
#define MAX_RENDER_PIXELS (256 * 1024)

/* ---- seed graphs ------------------------------------------------------------------------- */

/* The subgraph, written next to the in-memory graphs so type="fuzz_sub" finds it. */
static const char *const sub_xml =
    "<wetgraph version=\"1\" size=\"16\">\n"
    "  <param name=\"mode\" type=\"enum\" values=\"multiply|screen|add\" default=\"screen\"/>\n"
    "  <param name=\"amount\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"base\" type=\"color\" default=\"#808080\"/>\n"
    "  <input name=\"mask\" type=\"gray\"/>\n"
    "  <node id=\"fg\" type=\"uniform\" value=\"=amount\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"=mode\" opacity=\"=amount\">\n"
    "    <in name=\"foreground\" from=\"fg\"/>\n"
    "    <in name=\"background\" from=\"$base\"/>\n"
    "    <in name=\"mask\" from=\"$mask\"/>\n"
    "  </node>\n"
    "  <output name=\"out\" from=\"mix\"/>\n"
    "  <output name=\"mask\" from=\"$mask\"/>\n"
    "</wetgraph>\n";

static const char *const seeds[] = {
    /* parameters of every type, inputs, expressions, sizes, the foundation nodes */
    "<wetgraph version=\"1\" size=\"32x16\" seed=\"7\" label=\"fuzz seed\">\n"
    "  <param name=\"amount\" type=\"float\" default=\"0.25\" min=\"0\" max=\"1\" label=\"A\"/>\n"
    "  <param name=\"count\" type=\"int\" default=\"3\" min=\"1\" max=\"16\"/>\n"
    "  <param name=\"flip\" type=\"bool\" default=\"true\"/>\n"
    "  <param name=\"tint\" type=\"color\" default=\"#ff8000\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"multiply|screen|add\" default=\"screen\"/>\n"
    "  <param name=\"note\" type=\"string\" default=\"hello\"/>\n"
    "  <input name=\"base\" type=\"color\" colorspace=\"srgb\" default=\"#808080\"/>\n"
    "  <input name=\"height\" type=\"gray\" default=\"0.5\"/>\n"
    "  <input name=\"mask\" type=\"gray\"/>\n"
    "  <node id=\"fg\" type=\"uniform\" kind=\"color\" color=\"=tint\" pos=\"10 20\"/>\n"
    "  <node id=\"g\" type=\"uniform\" value=\"=amount * 2 - 0.1 + min(1, max($seed, 0)) * 0\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"=mode\"\n"
    "        opacity=\"=clamp(amount * count / 4, 0, 1)\" clamp=\"=!flip\" size=\"input\">\n"
    "    <in name=\"foreground\" from=\"fg\"/>\n"
    "    <in name=\"background\" from=\"$base\"/>\n"
    "    <in name=\"mask\" from=\"$mask\"/>\n"
    "  </node>\n"
    "  <!-- a comment -->\n"
    "  <node id=\"lv\" type=\"levels\" in_low=\"=amount\" in_mid=\"0.4\"\n"
    "        in_high=\"=amount + 0.5\" out_low=\"0.1\" out_high=\"0.9\" size=\"/2\">\n"
    "    <in name=\"source\" from=\"$height\"/>\n"
    "  </node>\n"
    "  <node id=\"soft\" type=\"blur\" sigma=\"=$width / 16 + ($time &gt; 1 ? 1 : 0)\" size=\"x2\""
    " seed=\"3\">\n"
    "    <in name=\"source\" from=\"mix.output\"/>\n"
    "  </node>\n"
    "  <node id=\"small\" type=\"blur\" sigma=\"0.5\" size=\"12x6\"><in name=\"source\" "
    "from=\"lv\"/></node>\n"
    "  <node id=\"bl2\" type=\"blend\" mode=\"multiply\" size=\"16\">\n"
    "    <in name=\"foreground\" from=\"g\"/><in name=\"background\" from=\"small\"/>\n"
    "  </node>\n"
    "  <output name=\"color\" from=\"soft\" format=\"exr\" colorspace=\"linear\"/>\n"
    "  <output name=\"raw\" from=\"$base\" format=\"png16\" colorspace=\"srgb\"/>\n"
    "  <output name=\"gray\" from=\"bl2.output\" format=\"png16\"/>\n"
    "</wetgraph>\n",

    /* generators and colour nodes, outputs by port */
    "<wetgraph version=\"1\" size=\"64\" seed=\"11\">\n"
    "  <param name=\"scale\" type=\"int\" default=\"4\" min=\"1\" max=\"64\"/>\n"
    "  <param name=\"metric\" type=\"enum\" values=\"euclidean|manhattan|chebyshev\"/>\n"
    "  <node id=\"n\" type=\"noise\" kind=\"simplex\" scale=\"=scale\" octaves=\"3\"\n"
    "        persistence=\"0.5\" lacunarity=\"2\" mode=\"ridged\"/>\n"
    "  <node id=\"c\" type=\"cells\" scale=\"=scale * 2\" jitter=\"0.8\" metric=\"=metric\" "
    "seed=\"5\"/>\n"
    "  <node id=\"b\" type=\"bricks\" columns=\"3\" rows=\"=scale\" row_offset=\"0.5\"\n"
    "        random_offset=\"0.2\" mortar=\"0.1\" bevel=\"0.2\" height_variation=\"0.3\"\n"
    "        luminance_variation=\"0.5\"/>\n"
    "  <node id=\"cv\" type=\"curve\" points=\"0:0.1 0.5:0.8 1:0.2\"><in name=\"source\" "
    "from=\"c.edges\"/></node>\n"
    "  <node id=\"gm\" type=\"gradient_map\" keys=\"0:#000000 0.5:#ff0000 1:#ffffff\" "
    "interpolation=\"smooth\">\n"
    "    <in name=\"source\" from=\"n\"/>\n"
    "  </node>\n"
    "  <node id=\"gr\" type=\"gradient\" kind=\"radial\" repeat=\"mirror\" angle=\"30\" "
    "count=\"2\"\n"
    "        center_x=\"0.25\" center_y=\"0.75\" radius=\"0.3\"/>\n"
    "  <node id=\"mx\" type=\"blend\" mode=\"overlay\" opacity=\"0.7\">\n"
    "    <in name=\"foreground\" from=\"gm\"/><in name=\"background\" from=\"b.height\"/>\n"
    "    <in name=\"mask\" from=\"gr\"/>\n"
    "  </node>\n"
    "  <output name=\"noise\" from=\"n\"/>\n"
    "  <output name=\"edges\" from=\"cv\" format=\"exr32\"/>\n"
    "  <output name=\"mask\" from=\"b.mask\"/>\n"
    "  <output name=\"id\" from=\"c.id\"/>\n"
    "  <output name=\"mixed\" from=\"mx\" format=\"png\" colorspace=\"srgb\"/>\n"
    "</wetgraph>\n",

    /* the pixel node: sample(), rgb(), noise(), extras, $-names */
    "<wetgraph version=\"1\" size=\"16x8\">\n"
    "  <param name=\"gain\" type=\"float\" default=\"1.5\" min=\"0\" max=\"10\"/>\n"
    "  <param name=\"shape\" type=\"enum\" values=\"a|b\" default=\"b\"/>\n"
    "  <input name=\"h\" type=\"gray\" default=\"0.25\"/>\n"
    "  <input name=\"col\" type=\"color\" default=\"0.2 0.4 0.6 1\"/>\n"
    "  <input name=\"req\" type=\"gray\"/>\n"
    "  <node id=\"src\" type=\"noise\" scale=\"2\" octaves=\"2\"/>\n"
    "  <node id=\"px\" type=\"pixel\" kind=\"color\" freq=\"=gain * 2\"\n"
    "        expr=\"rgb(sample(a, u * freq, v), sample(c.g, v, u) * gain, noise(u, v, 4)) *"
    " (shape + 1) + $time * 0 + (x &gt; y ? 0.1 : 0)\">\n"
    "    <in name=\"a\" from=\"src\"/>\n"
    "    <in name=\"c\" from=\"$col\"/>\n"
    "  </node>\n"
    "  <node id=\"pg\" type=\"pixel\" expr=\"h * 2 - fract(u * $width) + step(0.5, v) / "
    "max(gain, 1) + r\">\n"
    "    <in name=\"h\" from=\"$h\"/><in name=\"r\" from=\"$req\"/>\n"
    "  </node>\n"
    "  <node id=\"pc\" type=\"pixel\" kind=\"color\" expr=\"sample(c, u + $seed, v) * 0.5 + "
    "rgba(1, 0, pow(u, 2), 1)\">\n"
    "    <in name=\"c\" from=\"px\"/>\n"
    "  </node>\n"
    "  <output name=\"color\" from=\"px\"/>\n"
    "  <output name=\"gray\" from=\"pg.output\"/>\n"
    "  <output name=\"again\" from=\"pc\"/>\n"
    "</wetgraph>\n",

    /* a subgraph from a file, its enum forwarded with '=name' (another order of values) */
    "<wetgraph version=\"1\" size=\"24\">\n"
    "  <param name=\"blendmode\" type=\"enum\" values=\"add|multiply|screen\" "
    "default=\"multiply\"/>\n"
    "  <param name=\"level\" type=\"float\" default=\"0.6\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"height\" type=\"gray\" default=\"0.3\"/>\n"
    "  <node id=\"m\" type=\"threshold\" position=\"=level\" contrast=\"0.5\">\n"
    "    <in name=\"source\" from=\"$height\"/>\n"
    "  </node>\n"
    "  <node id=\"sub\" type=\"fuzz_sub\" mode=\"=blendmode\" amount=\"=level * 0.9\" "
    "size=\"/2\" seed=\"9\">\n"
    "    <in name=\"mask\" from=\"m\"/>\n"
    "  </node>\n"
    "  <node id=\"sub2\" type=\"fuzz_sub.wetgraph\" amount=\"0.1\">\n"
    "    <in name=\"mask\" from=\"sub.mask\"/>\n"
    "    <in name=\"base\" from=\"sub.out\"/>\n"
    "  </node>\n"
    "  <output name=\"out\" from=\"sub.out\"/>\n"
    "  <output name=\"out2\" from=\"sub2.out\" format=\"exr32\"/>\n"
    "</wetgraph>\n",

    /* the remaining families */
    "<wetgraph version=\"1\" size=\"20x12\" seed=\"3\">\n"
    "  <input name=\"c\" type=\"color\" default=\"#336699\"/>\n"
    "  <node id=\"ck\" type=\"checker\" scale=\"3\"/>\n"
    "  <node id=\"sn\" type=\"sine\" angle=\"45\" frequency=\"3\" phase=\"=$time\"/>\n"
    "  <node id=\"sh\" type=\"shape\" kind=\"star\" scale=\"2\" radius=\"0.7\" rotation=\"10\" "
    "sides=\"6\" inner_radius=\"0.4\" falloff=\"0.2\"/>\n"
    "  <node id=\"cl\" type=\"clamp\" min=\"0.2\" max=\"0.8\"><in name=\"source\" "
    "from=\"sn\"/></node>\n"
    "  <node id=\"al\" type=\"auto_levels\" mode=\"per_channel\"><in name=\"source\" "
    "from=\"$c\"/></node>\n"
    "  <node id=\"hs\" type=\"hsl\" hue=\"0.3\" saturation=\"-0.2\" lightness=\"0.1\"><in "
    "name=\"source\" from=\"al\"/></node>\n"
    "  <node id=\"cs\" type=\"colorspace\" direction=\"to_srgb\"><in name=\"source\" "
    "from=\"hs\"/></node>\n"
    "  <node id=\"sp\" type=\"split\"><in name=\"source\" from=\"cs\"/></node>\n"
    "  <node id=\"mg\" type=\"merge\" a=\"0.5\"><in name=\"r\" from=\"sp.g\"/><in name=\"b\" "
    "from=\"ck\"/><in name=\"g\" from=\"sh\"/></node>\n"
    "  <node id=\"sf\" type=\"shuffle\" r=\"b\" g=\"zero\" b=\"one\" a=\"r\"><in name=\"source\" "
    "from=\"mg\"/></node>\n"
    "  <node id=\"gs\" type=\"grayscale\" weights=\"0.3 0.6 0.1\"><in name=\"source\" "
    "from=\"sf\"/></node>\n"
    "  <node id=\"iv\" type=\"invert\" size=\"input\"><in name=\"source\" from=\"gs\"/></node>\n"
    "  <node id=\"img\" type=\"image\" path=\"fuzz.png\" colorspace=\"srgb\" kind=\"color\"/>\n"
    "  <node id=\"ib\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" "
    "from=\"img\"/><in name=\"background\" from=\"hs\"/></node>\n"
    "  <output name=\"a\" from=\"iv\"/>\n"
    "  <output name=\"img\" from=\"ib\"/>\n"
    "  <output name=\"b\" from=\"cl\"/>\n"
    "  <output name=\"c\" from=\"sp.a\"/>\n"
    "</wetgraph>\n",

    /* values near the float limits (from pixel, uniform, curve, gradient_map) through every
     * consumer, resampled up and down */
    "<wetgraph version=\"1\" size=\"12x10\" seed=\"5\">\n"
    "  <param name=\"k\" type=\"float\" default=\"3e38\"/>\n"
    "  <input name=\"hot\" type=\"color\" default=\"1e38 -2e38 3e38 1\"/>\n"
    "  <node id=\"hdr\" type=\"pixel\" kind=\"color\" k=\"=k\"\n"
    "        expr=\"rgb(u * k - k / 2, (v - 0.5) * 1e39, x / (y - 3))\"/>\n"
    "  <node id=\"hg\" type=\"pixel\" expr=\"(u - 0.3) / (v - 0.45) * 1e38\"/>\n"
    "  <node id=\"big\" type=\"uniform\" kind=\"color\" color=\"3.4e38 -3.4e38 1e38 2\"/>\n"
    "  <node id=\"gs\" type=\"grayscale\" weights=\"2 3 0.5\"><in name=\"source\" "
    "from=\"hdr\"/></node>\n"
    "  <node id=\"bl\" type=\"blur\" sigma=\"0.7\" size=\"/2\"><in name=\"source\" "
    "from=\"hdr\"/></node>\n"
    "  <node id=\"up\" type=\"levels\" in_low=\"-1e6\" in_high=\"1e6\" out_low=\"-1e6\" "
    "out_high=\"1e6\"\n"
    "        size=\"x2\"><in name=\"source\" from=\"hg\"/></node>\n"
    "  <node id=\"hs\" type=\"hsl\" hue=\"0.5\" saturation=\"0.5\" lightness=\"-0.5\"><in "
    "name=\"source\" from=\"big\"/></node>\n"
    "  <node id=\"cs\" type=\"colorspace\" direction=\"to_srgb\"><in name=\"source\" "
    "from=\"hdr\"/></node>\n"
    "  <node id=\"al\" type=\"auto_levels\"><in name=\"source\" from=\"hdr\"/></node>\n"
    "  <node id=\"th\" type=\"threshold\" position=\"0.3\" contrast=\"0.2\"><in "
    "name=\"source\" from=\"gs\"/></node>\n"
    "  <node id=\"cv\" type=\"curve\" points=\"-1e38:1e38 1e38:-1e38\"><in name=\"source\" "
    "from=\"hg\"/></node>\n"
    "  <node id=\"gm\" type=\"gradient_map\" keys=\"-1e38:1e38,0,0 1e38:0,0,-1e38\"><in "
    "name=\"source\" from=\"hg\"/></node>\n"
    "  <node id=\"mx\" type=\"blend\" mode=\"screen\" clamp=\"false\">\n"
    "    <in name=\"foreground\" from=\"bl\"/><in name=\"background\" from=\"$hot\"/>\n"
    "    <in name=\"mask\" from=\"hg\"/>\n"
    "  </node>\n"
    "  <node id=\"sb\" type=\"fuzz_sub\" amount=\"1\"><in name=\"mask\" from=\"gs\"/><in "
    "name=\"base\" from=\"big\"/></node>\n"
    "  <node id=\"sp\" type=\"split\"><in name=\"source\" from=\"hdr\"/></node>\n"
    "  <node id=\"mg\" type=\"merge\"><in name=\"r\" from=\"sp.r\"/><in name=\"g\" "
    "from=\"up\"/></node>\n"
    "  <node id=\"sf\" type=\"shuffle\" r=\"g\" g=\"r\"><in name=\"source\" "
    "from=\"mg\"/></node>\n"
    "  <node id=\"cl\" type=\"clamp\" min=\"-1e6\" max=\"1e6\"><in name=\"source\" "
    "from=\"sf\"/></node>\n"
    "  <node id=\"iv\" type=\"invert\"><in name=\"source\" from=\"big\"/></node>\n"
    "  <output name=\"gs\" from=\"gs\"/><output name=\"bl\" from=\"bl\"/>\n"
    "  <output name=\"up\" from=\"up\"/><output name=\"hs\" from=\"hs\"/>\n"
    "  <output name=\"cs\" from=\"cs\"/><output name=\"al\" from=\"al\"/>\n"
    "  <output name=\"th\" from=\"th\"/><output name=\"cv\" from=\"cv\"/>\n"
    "  <output name=\"gm\" from=\"gm\"/><output name=\"mx\" from=\"mx\"/>\n"
    "  <output name=\"sb\" from=\"sb.out\"/><output name=\"cl\" from=\"cl\"/>\n"
    "  <output name=\"iv\" from=\"iv\"/>\n"
    "</wetgraph>\n",
};
enum { N_SEEDS = sizeof seeds / sizeof seeds[0] };

/* ---- regressions: a minimal graph for every bug found ------------------------------------ */

/* n copies of s, at compile time */
#define X10(s) s s s s s s s s s s
#define X1000(s) X10(X10(X10(s)))
#define ID255 X10(X10("aa") "a") X10("aaaa") "aaaaa" /* an id of 255 letters */

typedef struct {
    const char *name;
    const char *xml;
    int status;         /* what run_one must return: the first failing status, or WG_OK */
    const char *needle; /* in the formatted error (NULL: not checked) */
} Regression;

static const Regression regressions[] = {
    /* a colour component beyond the float range became infinity (the NaN then spread) */
    {"colour_beyond_float",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"u\" type=\"uniform\" kind=\"color\" color=\"1e39 0 0\"/>\n"
     "  <output name=\"o\" from=\"u\"/>\n"
     "</wetgraph>\n",
     WG_ERR_TYPE, "expects a colour"},
    /* a slope beyond the double range (points 1e-300 apart) made the tangents inf and NaN */
    {"curve_slope_overflow",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"u\" type=\"uniform\" value=\"0.5\"/>\n"
     "  <node id=\"c\" type=\"curve\" points=\"0:-1e38 1e-300:0 1:1e38\">\n"
     "    <in name=\"source\" from=\"u\"/>\n"
     "  </node>\n"
     "  <node id=\"d\" type=\"curve\" points=\"0:-1e38 1e-30:0 1:1e-300\">\n"
     "    <in name=\"source\" from=\"u\"/>\n"
     "  </node>\n"
     "  <output name=\"c\" from=\"c\"/>\n"
     "  <output name=\"d\" from=\"d\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* blending huge finite values overflowed float intermediates: 2·A·B = inf·0 = NaN, also
     * where the mask is 0 and in clamped mode */
    {"blend_overflow",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"big\" type=\"uniform\" kind=\"color\" color=\"3e38 -3e38 3e38\"/>\n"
     "  <node id=\"zero\" type=\"uniform\" value=\"0\"/>\n"
     "  <node id=\"o\" type=\"blend\" mode=\"overlay\">\n"
     "    <in name=\"foreground\" from=\"big\"/><in name=\"background\" from=\"zero\"/>\n"
     "    <in name=\"mask\" from=\"zero\"/>\n"
     "  </node>\n"
     "  <node id=\"s\" type=\"blend\" mode=\"soft_light\" clamp=\"false\">\n"
     "    <in name=\"foreground\" from=\"big\"/><in name=\"background\" from=\"zero\"/>\n"
     "  </node>\n"
     "  <node id=\"a\" type=\"blend\" mode=\"add\" clamp=\"false\">\n"
     "    <in name=\"foreground\" from=\"big\"/><in name=\"background\" from=\"big\"/>\n"
     "  </node>\n"
     "  <output name=\"o\" from=\"o\"/>\n"
     "  <output name=\"s\" from=\"s\"/>\n"
     "  <output name=\"a\" from=\"a\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* grayscale summed weight·channel products in float: 3·3e38 became infinity */
    {"grayscale_overflow",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"big\" type=\"uniform\" kind=\"color\" color=\"3e38 -3e38 3e38\"/>\n"
     "  <node id=\"g\" type=\"grayscale\" weights=\"3 -3 3\"><in name=\"source\" "
     "from=\"big\"/></node>\n"
     "  <output name=\"g\" from=\"g\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* resampling: float weights summing just above 1 carried values near FLT_MAX to inf */
    {"resample_overflow",
     "<wetgraph version=\"1\" size=\"8\">\n"
     "  <node id=\"big\" type=\"pixel\" expr=\"min(x, 1) * 1e39\"/>\n"
     "  <node id=\"small\" type=\"invert\" size=\"3\"><in name=\"source\" "
     "from=\"big\"/></node>\n"
     "  <output name=\"small\" from=\"small\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* a colour input's default also went into the gray `value` of its uniform, whose range
     * refused 1e38 with an error about a 'value' nobody wrote, blamed on the consumer */
    {"colour_input_default_beyond_1e6",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <input name=\"hot\" type=\"color\" default=\"1e38 -2e38 3e38 1\"/>\n"
     "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$hot\"/></node>\n"
     "  <output name=\"i\" from=\"i\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* and a gray default beyond that range is refused where it is written */
    {"gray_input_default_beyond_1e6",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <input name=\"h\" type=\"gray\" default=\"2e6\"/>\n"
     "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$h\"/></node>\n"
     "  <output name=\"i\" from=\"i\"/>\n"
     "</wetgraph>\n",
     WG_ERR_RANGE, "fuzz.wetgraph:2: default '2e6' of gray input 'h' is outside"},
    /* an entity reference is neither text nor element to the loader: it hid text, and whole
     * elements, where only elements belong */
    {"entity_reference",
     "<!DOCTYPE wetgraph [<!ENTITY n \"<node id='q' type='uniform'/>\">]>\n"
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"u\" type=\"uniform\"/>\n"
     "  &n;\n"
     "  <output name=\"o\" from=\"u\"/>\n"
     "</wetgraph>\n",
     WG_ERR_PARSE, "fuzz.wetgraph:4: unexpected entity reference '&n;' inside <wetgraph>"},
    /* sRGB decoding of a file's values above ~1e16 gave infinity (the file itself is finite) */
    {"srgb_decode_overflow",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"i\" type=\"image\" path=\"fuzz_huge.exr\" colorspace=\"srgb\"/>\n"
     "  <output name=\"i\" from=\"i\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* a node failing while it ran (here: a NaN found when the file is read) was reported by
     * copying the error through the caller's WgError pointer, also when that was NULL */
    {"eval_error_without_wgerror",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"i\" type=\"image\" path=\"fuzz_nan.exr\"/>\n"
     "  <output name=\"i\" from=\"i\"/>\n"
     "</wetgraph>\n",
     WG_ERR_RANGE, "fuzz_nan.exr: image has 1 non-finite values"},
    /* clang-format off */
    /* a long chain a + b + ... is a tree as tall as it is long: evaluators that recursed over
     * the tree overflowed the stack (the pixel compiler at ~20000 terms, the parameter
     * evaluator at ~100000); they walk the postorder node array instead, so these render */
    {"long_chain_pixel",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"p\" type=\"pixel\" expr=\"x" X1000(X10(X10("+x"))) "\"/>\n"
     "  <output name=\"p\" from=\"p\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    {"long_chain_parameter",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"u\" type=\"uniform\" value=\"=0" X1000(X10(X10("+0"))) "\"/>\n"
     "  <output name=\"u\" from=\"u\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    /* clang-format on */
    /* a reference was looked up through a 256-byte copy: a longer id was cut short and found
     * another node (here a colour one, for a gray port) */
    {"long_node_id",
     "<wetgraph version=\"1\" size=\"4\">\n"
     "  <node id=\"" ID255 "\" type=\"uniform\" kind=\"color\"/>\n"
     "  <node id=\"" ID255 "bbb\" type=\"uniform\" value=\"0.5\"/>\n"
     "  <node id=\"b\" type=\"blend\">\n"
     "    <in name=\"foreground\" from=\"b" ID255 "\"/><in name=\"background\" from=\"" ID255
     "\"/>\n"
     "    <in name=\"mask\" from=\"" ID255 "bbb.output\"/>\n"
     "  </node>\n"
     "  <node id=\"b" ID255 "\" type=\"uniform\" kind=\"color\"/>\n"
     "  <output name=\"o\" from=\"b\"/>\n"
     "</wetgraph>\n",
     WG_OK, NULL},
    {NULL, NULL, 0, NULL},
};

/* ---- a deterministic stream -------------------------------------------------------------- */

static uint64_t rng_state;

static uint64_t rnd(void)
{
    uint64_t x = rng_state; /* xorshift64* */
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    rng_state = x;
    return x * 0x2545F4914F6CDD1DULL;
}

static size_t below(size_t n)
{
    return n ? (size_t)(rnd() % n) : 0;
}

/* ---- a growable buffer ------------------------------------------------------------------- */

typedef struct {
    char *p;
    size_t n, cap;
} Buf;

static void buf_reserve(Buf *b, size_t n)
{
    if (n + 1 <= b->cap) return;
    size_t cap = b->cap ? b->cap : 256;
    while (cap < n + 1) cap *= 2;
    b->p = realloc(b->p, cap);
    assert_non_null(b->p);
    b->cap = cap;
}

static void buf_set(Buf *b, const char *s, size_t n)
{
    buf_reserve(b, n);
    memmove(b->p, s, n);
    b->n = n;
    b->p[n] = '\0';
}

/* Replace [at, at + len) with n bytes of s (s must not point into b). */
static void buf_splice(Buf *b, size_t at, size_t len, const char *s, size_t n)
{
    if (at > b->n) at = b->n;
    if (len > b->n - at) len = b->n - at;
    buf_reserve(b, b->n - len + n);
    memmove(b->p + at + n, b->p + at + len, b->n - at - len);
    memcpy(b->p + at, s, n);
    b->n = b->n - len + n;
    b->p[b->n] = '\0';
}

/* ---- mutations --------------------------------------------------------------------------- */

/* clang-format off */
static const char *const tokens[] = {
    "\"", "'", "<", ">", "=", "/>", "</", "&amp;", "&#0;", "&#x10FFFF;", "&lt;", "&bogus;", "&",
    "=1/0", "=1e308*10", "nan", "-nan", "inf", "-1", "99999", "1e39", "-1e39", "$", "(", ")", "x0",
    "/0", "16385", "16384", ".", ",", ":", "|", "?", "^", "-", "!", "#", "\n", " ", "\t", "<!--",
    "-->", "<![CDATA[x]]>", "<?pi x?>", "<!DOCTYPE wetgraph>", "\xff", "\xc3", "\x80",
    "<node id=\"z\" type=\"uniform\"/>", "<in name=\"source\" from=\"z\"/>",
    "<output name=\"zz\" from=\"z\"/>", "<param name=\"p\" type=\"float\"/>",
    "<input name=\"q\" type=\"color\"/>", "</node>", "</wetgraph>", "<wetgraph version=\"1\">",
    " type=\"fuzz\"", " type=\"fuzz_sub\"", " size=\"input\"", " size=\"$base\"", " seed=\"-1\"",
    " allow_nonfinite=\"true\"", " from=\"$height\"", ".output", ".f2", ".mask", "$width",
    "$height", "$seed", "$time", "sample(", "rgb(", "noise(", "1e-45", "0x", "mix.", "sub.", "&a;",
    "&n;", "&x;", "&big;", "&nosuch;",
};
/* clang-format on */
enum { N_TOKENS = sizeof tokens / sizeof tokens[0] };

/* clang-format off */
static const char *const values[] = {
    "0", "-0", "1", "-1", "0.5", "1e308", "-1e308", "1e39", "-1e39", "3.4028236e38", "1e-45",
    "1e-320", "nan", "NaN", "inf", "-inf", "infinity", "99999", "16384", "16385", "65536",
    "2147483647", "2147483648", "-2147483649", "4294967296", "9223372036854775808",
    "18446744073709551615", "18446744073709551616", "0x10", "1e", "", " ", "  1  ", "=1/0",
    "=1e308*10", "=0/0", "=-1", "=$width*99999", "=$seed", "=$time", "=$height/0", "=(", "=", "=$",
    "=x0", "=1?2", "=max(1)", "=min(1,2,3,4,5)", "=sample(a,u,v)", "=rgb(1,2,3)", "=1e39", "=-1e39",
    "=2^1024", "=log(0)", "=sqrt(-1)", "=16385", "=16384", "=amount", "=mode", "=tint", "=note",
    "=!flip", "=blendmode", "=scale", "=level", "=gain", "=shape", "=metric", "= mode ",
    "=-2147483649", "=1e10", "=-1e10", "=$width*$height*1e6", "x0", "x2", "x16384", "x1e-9", "/0",
    "/2", "/1e300", "/16384", "x16385", "/-1", "x", "/", "input", "graph", "8x8", "0x8",
    "16384x16384", "16385x1", "1x1", "1x16384", "4x", "x4", "$base", "$mask", "$height", "$",
    "#fff", "#12345", "#gggggg", "#ffffffff", "0 0 0", "1 2", "nan nan nan", "1e39 0 0", "a|b|c",
    "|||", ",", "0:0 1:1", "0:#000 1:#fff", "0:0", "1:1 1:1", "5:#fff -5:#000", "1e39:1", "nan:1",
    "0:nan", "0:1e38 1:-1e38", "0:-1e38 1e-300:0 1:1e38", "0:3.4e38 1e-30:-3.4e38",
    "-3.4e38:#fff 3.4e38:#000", "0:-3.4e38,3.4e38,0 1:3.4e38", "1e-300:1 2e-300:0", "3.4e38",
    "-3.4e38", "3.4028234e38", "1e38", "-1e38", "1e38 -1e38 1e38", "=k", "=k * -1", "1/0", "-1/0",
    "rgb(1/0, -1/0, 0/0)", "x * 3e38 - 1e38", "(u - 0.5) * 1e39", "sample(hdr, u * 3, v) * 1e30",
    "fuzz.png", "fuzz_gray16.png", "fuzz_nan.exr", "fuzz_huge.exr", "fuzz_bad.png", "nosuch.png",
    "auto", "mix", "mix.output", "fg", "sub.out", "sub.nosuch", "c.f3", "b.height", "n.", ".", "..",
    "a.b.c", "fuzz_sub", "fuzz", "fuzz_sub.wetgraph", "fuzz.wetgraph", "../fuzz_sub.wetgraph", "/",
    "/dev/null", "noise", "pixel", "true", "false", "yes", "2", "multiply", "screen", "nosuch",
    "color", "gray", "srgb", "linear", "exr", "png", "tif16", "u", "v", "x", "y", "sample(a, u, v)",
    "sample(c, nan, v)", "1/0", "0/0", "rgb(1/0, 0, 0)", "sample(c.q, u, v)", "noise(u, v, 1e39)",
    "noise(u, v, -1)", "noise(u, v, 0/0)", "a ? b : c", "rgb(1,1,1) ? 1 : 0", "1 ? rgb(1,1,1) : 0",
    "pow(-1, 0.5)", "mod(1, 0)", "x / 0 * 0",
};
/* clang-format on */
enum { N_VALUES = sizeof values / sizeof values[0] };

/* clang-format off */
static const char *const attr_names[] = {
    "value", "color", "kind", "mode", "opacity", "clamp", "sigma", "in_low", "in_mid", "in_high",
    "out_low", "out_high", "scale", "octaves", "persistence", "lacunarity", "jitter", "metric",
    "columns", "rows", "row_offset", "mortar", "bevel", "points", "keys", "interpolation", "repeat",
    "angle", "count", "radius", "center_x", "expr", "allow_nonfinite", "size", "seed", "id", "type",
    "from", "name", "default", "min", "max", "values", "format", "colorspace", "version", "label",
    "pos", "amount", "level", "blendmode", "sides", "inner_radius", "falloff", "frequency", "phase",
    "hue", "saturation", "lightness", "direction", "weights", "r", "g", "position", "contrast",
    "path", "freq",
};
/* clang-format on */
enum { N_ATTR_NAMES = sizeof attr_names / sizeof attr_names[0] };

static void huge_string(Buf *out)
{
    static const char *const units[] = {"a", "(",      ")",       "-", "1+",    "sin(",
                                        "$", "0:0 ",   "0:#fff ", "<", "&amp;", "x",
                                        "9", "<node>", "=",       " ", "\"",    "!"};
    const char *u = units[below(sizeof units / sizeof units[0])];
    size_t reps = 64 + below(4096);
    out->n = 0;
    for (size_t i = 0; i < reps; i++) buf_splice(out, out->n, 0, u, strlen(u));
}

/* Positions just after each `key="` in b, up to max. */
static int find_values(const Buf *b, const char *key, size_t *starts, size_t *ends, int max)
{
    int n = 0;
    size_t kl = strlen(key);
    for (const char *p = b->p; n < max && (p = strstr(p, key)); p += kl) {
        const char *v = p + kl;
        const char *close = strchr(v, '"');
        if (!close) break;
        starts[n] = (size_t)(v - b->p);
        ends[n] = (size_t)(close - b->p);
        n++;
    }
    return n;
}

/* Values of the parameter attributes of <node> elements (not id or type): the mutations that
 * keep a graph loadable most often. */
static int find_params(const Buf *b, size_t *starts, size_t *ends, int max)
{
    int n = 0;
    for (const char *p = b->p; n < max && (p = strstr(p, "<node ")); p++) {
        const char *gt = strchr(p, '>');
        if (!gt) break;
        for (const char *q = p + 6; n < max;) {
            const char *eq = strstr(q, "=\"");
            if (!eq || eq > gt) break;
            const char *name = eq;
            while (name > q && name[-1] != ' ' && name[-1] != '\n') name--;
            const char *close = strchr(eq + 2, '"');
            if (!close) break;
            size_t len = (size_t)(eq - name);
            if (!(len == 2 && !strncmp(name, "id", 2)) &&
                !(len == 4 && !strncmp(name, "type", 4))) {
                starts[n] = (size_t)(eq + 2 - b->p);
                ends[n] = (size_t)(close - b->p);
                n++;
            }
            q = close + 1;
            if (close > gt) gt = strchr(close, '>'); /* a '>' inside a value */
            if (!gt) break;
        }
    }
    return n;
}

/* A parameter value (mostly) or any attribute value (sometimes). */
static int find_target(const Buf *b, size_t *starts, size_t *ends, int max)
{
    int k = below(4) ? find_params(b, starts, ends, max) : 0;
    return k ? k : find_values(b, "=\"", starts, ends, max);
}

static void pick_value(Buf *v)
{
    if (below(16) == 0) {
        huge_string(v);
    } else {
        const char *s = values[below(N_VALUES)];
        buf_set(v, s, strlen(s));
    }
}

/* A random expression, mostly well formed: numbers of every size, the names the seeds define
 * (and some they do not), every operator and function with right and wrong arities, pixel
 * functions on gray and colour inputs. XML-escaped. */
static void gen_expr(Buf *o, int depth, bool pixel)
{
    static const char *const numbers[] = {"0",    "1",     "0.5",   "2",    "-1", "3e38",
                                          "1e38", "1e-45", "1e308", "1e39", "7",  "0.001"};
    static const char *const everywhere[] = {"$time", "$seed", "$width", "$height"};
    static const char *const in_pixels[] = {"u", "v", "x", "y"};
    static const char *const seed_names[] = {"a",      "c",     "c.r",  "c.g",  "c.a",   "h",
                                             "hdr",    "hdr.b", "freq", "gain", "k",     "shape",
                                             "amount", "count", "flip", "mode", "scale", "level",
                                             "nosuch", "c.q",   "tint", "note"};
    static const char *const binops[] = {
        " + ",     " - ",    " * ",     " / ",  " % ",  " ^ ",          " &lt; ",
        " &lt;= ", " &gt; ", " &gt;= ", " == ", " != ", " &amp;&amp; ", " || "};
    static const char *const funcs[] = {
        "abs",   "min",    "max",   "clamp", "lerp", "mix",   "smoothstep", "step",
        "floor", "ceil",   "fract", "mod",   "sqrt", "pow",   "exp",        "log",
        "sin",   "cos",    "tan",   "asin",  "acos", "atan",  "atan2",      "round",
        "sign",  "sample", "noise", "rgb",   "rgba", "nosuch"};
    static const int arity[] = {1, 2, 2, 3, 3, 3, 3, 2, 1, 1, 1, 2, 1, 2, 1,
                                1, 1, 1, 1, 1, 1, 1, 2, 1, 1, 3, 3, 3, 4, 1};
    if (o->n > 4000) depth = 99;
    size_t pick = depth > 5 ? 0 : below(10);
    const char *t;
    switch (pick) {
    case 0:
    case 1:
    case 2: {
        size_t r = below(10);
        if (r < 5)
            t = numbers[below(sizeof numbers / sizeof numbers[0])];
        else if (r < 7)
            t = everywhere[below(4)];
        else if (r < 9 && pixel)
            t = in_pixels[below(4)];
        else
            t = seed_names[below(sizeof seed_names / sizeof seed_names[0])];
        buf_splice(o, o->n, 0, t, strlen(t));
        break;
    }
    case 3:
    case 4:
    case 5:
        gen_expr(o, depth + 1, pixel);
        t = binops[below(sizeof binops / sizeof binops[0])];
        buf_splice(o, o->n, 0, t, strlen(t));
        gen_expr(o, depth + 1, pixel);
        break;
    case 6:
        t = below(3) ? "-" : below(2) ? "!" : "+";
        buf_splice(o, o->n, 0, t, strlen(t));
        gen_expr(o, depth + 1, pixel);
        break;
    case 7:
        buf_splice(o, o->n, 0, "(", 1);
        gen_expr(o, depth + 1, pixel);
        if (below(16)) buf_splice(o, o->n, 0, ")", 1);
        break;
    case 8:
        gen_expr(o, depth + 1, pixel);
        buf_splice(o, o->n, 0, " ? ", 3);
        gen_expr(o, depth + 1, pixel);
        buf_splice(o, o->n, 0, " : ", 3);
        gen_expr(o, depth + 1, pixel);
        break;
    default: {
        size_t f = below(sizeof funcs / sizeof funcs[0]);
        int n = below(8) ? arity[f] : (int)below(6);
        buf_splice(o, o->n, 0, funcs[f], strlen(funcs[f]));
        buf_splice(o, o->n, 0, "(", 1);
        for (int i = 0; i < n; i++) {
            if (i) buf_splice(o, o->n, 0, ", ", 2);
            if (i == 0 && !strcmp(funcs[f], "sample")) {
                static const char *const imgs[] = {"a", "c", "c.g", "hdr", "h", "u", "1"};
                t = imgs[below(sizeof imgs / sizeof imgs[0])];
                buf_splice(o, o->n, 0, t, strlen(t));
            } else {
                gen_expr(o, depth + 1, pixel);
            }
        }
        buf_splice(o, o->n, 0, ")", 1);
        break;
    }
    }
}

static void mutate_once(Buf *b)
{
    size_t n = b->n;
    Buf tmp = {0};
    /* byte-level damage mostly tests the XML error paths; the structural mutations (the later
     * cases) keep more mutants loadable, so they get most of the draws */
    static const unsigned char kinds[] = {0,  1,  2,  3,  4,  5,  6,  13, 15, 7,  7,
                                          8,  8,  14, 14, 14, 14, 9,  9,  10, 10, 10,
                                          11, 11, 12, 12, 12, 16, 16, 16, 16};
    switch (kinds[below(sizeof kinds)]) {
    case 0: /* flip a bit */
        if (n) b->p[below(n)] ^= (char)(1u << below(8));
        break;
    case 1: { /* one byte of a kind the parser cares about */
        static const char bytes[] = "<>\"'=/&;# \n\tx$().:|,-0\x01\x7f\x80\xff";
        if (n) b->p[below(n)] = bytes[below(sizeof bytes - 1)];
        break;
    }
    case 2: { /* delete a span */
        size_t at = below(n + 1), len = below(4) ? 1 + below(16) : below(n / 4 + 1);
        buf_splice(b, at, len, "", 0);
        break;
    }
    case 3: { /* duplicate a span somewhere */
        size_t at = below(n + 1), len = 1 + below(below(2) ? 32 : 400);
        if (at + len > n) len = n - at;
        buf_set(&tmp, b->p + at, len);
        buf_splice(b, below(n + 1), 0, tmp.p, tmp.n);
        break;
    }
    case 4: { /* swap two spans */
        if (n < 4) break;
        size_t half = n / 2, a = rnd() % half, c = half + rnd() % (n - half);
        size_t la = 1 + below(48), lc = 1 + below(48);
        if (la > half - a) la = half - a;
        if (lc > n - c) lc = n - c;
        Buf x = {0};
        buf_set(&tmp, b->p + a, la);
        buf_set(&x, b->p + c, lc);
        buf_splice(b, c, lc, tmp.p, tmp.n);
        buf_splice(b, a, la, x.p, x.n);
        free(x.p);
        break;
    }
    case 5: { /* insert a token */
        const char *t = tokens[below(N_TOKENS)];
        buf_splice(b, below(n + 1), 0, t, strlen(t));
        break;
    }
    case 6: { /* truncate: anywhere, or just before or after a character of some class */
        static const char cls[] = "<>\"=/ \n!-$.x";
        size_t at = below(n + 1);
        if (below(3)) {
            char c = cls[below(sizeof cls - 1)];
            size_t hits[512];
            int k = 0;
            for (size_t i = 0; i < n && k < 512; i++)
                if (b->p[i] == c) hits[k++] = i;
            if (k) at = hits[below((size_t)k)] + below(2);
        }
        if (at > n) at = n;
        b->n = at;
        b->p[at] = '\0';
        break;
    }
    case 7:
    case 8: { /* replace an attribute value with an extreme one */
        size_t s[256], e[256];
        int k = find_target(b, s, e, 256);
        if (!k) break;
        int i = (int)below((size_t)k);
        pick_value(&tmp);
        buf_splice(b, s[i], e[i] - s[i], tmp.p, tmp.n);
        break;
    }
    case 9: { /* duplicate a whole <node> element (with its <in>s), here or elsewhere */
        size_t starts[128];
        int k = 0;
        for (const char *p = b->p; k < 128 && (p = strstr(p, "<node")); p++)
            starts[k++] = (size_t)(p - b->p);
        if (!k) break;
        size_t at = starts[below((size_t)k)];
        const char *gt = strchr(b->p + at, '>');
        if (!gt) break;
        size_t end = (size_t)(gt - b->p) + 1;
        if (gt[-1] != '/') {
            const char *close = strstr(gt, "</node>");
            if (close) end = (size_t)(close - b->p) + 7;
        }
        buf_set(&tmp, b->p + at, end - at);
        if (below(2)) { /* a copy under a new id is loadable */
            const char *id = strstr(tmp.p, "id=\"");
            if (id) buf_splice(&tmp, (size_t)(id - tmp.p) + 4, 0, "dup", 3);
        }
        buf_splice(b, below(2) ? end : starts[below((size_t)k)], 0, tmp.p, tmp.n);
        break;
    }
    case 10: { /* point a reference at a node id (cycles, self loops, ports that do not exist) */
        size_t is[128], ie[128], fs[128], fe[128];
        int ni = find_values(b, "id=\"", is, ie, 128);
        int nf = find_values(b, "from=\"", fs, fe, 128);
        if (!ni) break;
        int i = (int)below((size_t)ni);
        buf_set(&tmp, b->p + is[i], ie[i] - is[i]);
        if (below(4) == 0) {
            static const char *const ports[] = {".output", ".f1", ".edges", ".mask", ".out", ".x"};
            const char *pt = ports[below(6)];
            buf_splice(&tmp, tmp.n, 0, pt, strlen(pt));
        }
        if (nf && below(4)) {
            int f = (int)below((size_t)nf);
            buf_splice(b, fs[f], fe[f] - fs[f], tmp.p, tmp.n);
        } else { /* swap the ids of two nodes: ids stay unique, edges turn around */
            int j = (int)below((size_t)ni);
            if (j == i || is[j] < ie[i] + 1) break;
            Buf x = {0};
            buf_set(&x, b->p + is[j], ie[j] - is[j]);
            buf_splice(b, is[j], ie[j] - is[j], tmp.p, ie[i] - is[i]);
            buf_splice(b, is[i], ie[i] - is[i], x.p, x.n);
            free(x.p);
        }
        break;
    }
    case 11: { /* change a node's type */
        size_t s[128], e[128];
        int k = find_values(b, "type=\"", s, e, 128);
        if (!k) break;
        int i = (int)below((size_t)k);
        const char *t;
        size_t nt = 0;
        while (wg_node_types[nt]) nt++;
        size_t pick = below(nt + 6);
        static const char *const other[] = {"fuzz_sub", "fuzz", "fuzz_sub.wetgraph",
                                            "nosuch",   "",     "fuzz.wetgraph"};
        t = pick < nt ? wg_node_types[pick]->name : other[pick - nt];
        buf_splice(b, s[i], e[i] - s[i], t, strlen(t));
        break;
    }
    case 12: { /* add an attribute to some element */
        size_t starts[256];
        int k = 0;
        for (const char *p = b->p; k < 256 && (p = strstr(p, " id=\"")); p++)
            starts[k++] = (size_t)(p - b->p);
        for (const char *p = b->p; k < 256 && (p = strstr(p, " name=\"")); p++)
            starts[k++] = (size_t)(p - b->p);
        if (!k) break;
        pick_value(&tmp);
        const char *name = attr_names[below(N_ATTR_NAMES)];
        buf_splice(&tmp, 0, 0, "=\"", 2);
        buf_splice(&tmp, 0, 0, name, strlen(name));
        buf_splice(&tmp, 0, 0, " ", 1);
        buf_splice(&tmp, tmp.n, 0, "\"", 1);
        buf_splice(b, starts[below((size_t)k)], 0, tmp.p, tmp.n);
        break;
    }
    case 14: { /* a number of any magnitude, or at a boundary, into an attribute value */
        size_t s[256], e[256];
        int k = find_target(b, s, e, 256);
        if (!k) break;
        int i = (int)below((size_t)k);
        static const double edges[] = {0,    1,  -1, 0.5, 1e6, -1e6, 16384,  16385,   4096,
                                       4097, 64, 65, 16,  17,  256,  257,    0.001,   0.999,
                                       0.05, 3,  2,  4,   5,   1e-6, 3.4e38, -3.4e38, 1e38};
        char num[64];
        switch (below(4)) {
        case 0:
            snprintf(num, sizeof num, "%.9g", edges[below(sizeof edges / sizeof edges[0])]);
            break;
        case 1: /* a power of ten, either sign */
            snprintf(num, sizeof num, "%s1e%d", below(2) ? "-" : "", (int)below(80) - 42);
            break;
        case 2: /* a small fraction or integer */
            snprintf(num, sizeof num, "%.3f", (double)(int64_t)(rnd() % 4001) / 1000 - 2);
            break;
        default: /* the same as an expression */
            snprintf(num, sizeof num, "=%.17g * %d", edges[below(sizeof edges / sizeof edges[0])],
                     (int)below(3) - 1);
            break;
        }
        buf_splice(b, s[i], e[i] - s[i], num, strlen(num));
        break;
    }
    case 15: { /* a document type declaring entities and attribute defaults */
        static const char *const dtds[] = {
            "<!DOCTYPE wetgraph [<!ENTITY a \"0.5\"><!ENTITY n \"<node id='q' "
            "type='uniform'/>\"><!ENTITY x SYSTEM \"/etc/hostname\">]>\n",
            "<!DOCTYPE wetgraph [<!ATTLIST node size CDATA \"x2\" seed CDATA \"4\">]>\n",
            "<!DOCTYPE wetgraph [<!ENTITY a \"aaaaaaaaaa\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;\">"
            "<!ENTITY big \"&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;\">]>\n",
            "<!DOCTYPE wetgraph SYSTEM \"/etc/hostname\">\n",
            "<?xml version=\"1.0\" encoding=\"UTF-16\"?>\n",
            "<?xml version=\"1.1\" encoding=\"ISO-8859-1\" standalone=\"yes\"?>\n",
        };
        const char *t = dtds[below(sizeof dtds / sizeof dtds[0])];
        buf_splice(b, 0, 0, t, strlen(t));
        break;
    }
    case 16: { /* a random expression: a pixel node's expr, or any parameter as '=...' */
        size_t s[256], e[256];
        int k = find_values(b, "expr=\"", s, e, 256);
        bool pixel = k && below(2);
        if (!pixel) k = find_params(b, s, e, 256);
        if (!k) break;
        int i = (int)below((size_t)k);
        if (!pixel) buf_set(&tmp, "=", 1);
        gen_expr(&tmp, below(4) ? 0 : 3, pixel);
        buf_splice(b, s[i], e[i] - s[i], tmp.p, tmp.n);
        break;
    }
    case 13: { /* a huge string somewhere */
        huge_string(&tmp);
        buf_splice(b, below(n + 1), 0, tmp.p, tmp.n);
        break;
    }
    }
    free(tmp.p);
    if (b->n > MAX_MUTANT) {
        b->n = MAX_MUTANT;
        b->p[b->n] = '\0';
    }
}

/* ---- running one graph ------------------------------------------------------------------- */

typedef struct {
    long mutants, loaded, checked, rendered, rendered2, too_big, bad;
} Stats;

static bool keep_going, verbose;
static const char *current_xml; /* for the watchdog */
static size_t current_len;
static long current_index;
static const char *current_sub; /* the mutant, when it runs as the subgraph fuzz_mut */

static void print_graph(FILE *f, const char *xml, size_t len)
{
    fputs("---- graph ----\n", f);
    fwrite(xml, 1, len > 6000 ? 6000 : len, f);
    if (len > 6000) fprintf(f, "\n... (%zu bytes in all)", len);
    fputs("\n---- end ----\n", f);
}

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "\nfuzz: a mutant did not finish (watchdog); it was:\n";
    ssize_t r = write(2, msg, sizeof msg - 1);
    if (current_xml) r = write(2, current_xml, current_len > 6000 ? 6000 : current_len);
    (void)r;
    abort();
}

/* Failures must be clean: negative status, err.code the same, a message, a line >= 0. */
static void report(Stats *st, const char *stage, const char *xml, size_t len, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
static void report(Stats *st, const char *stage, const char *xml, size_t len, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    st->bad++;
    printf("fuzz: mutant %ld, %s: %s\n", current_index, stage, msg);
    print_graph(stdout, xml, len);
    if (current_sub) {
        printf("used as the subgraph fuzz_mut.wetgraph:\n");
        print_graph(stdout, current_sub, strlen(current_sub));
    }
    fflush(stdout);
    if (!keep_going) fail_msg("fuzz: %s: %s", stage, msg);
}

static char last_error[2200]; /* the last failure, formatted */

static bool clean_failure(Stats *st, const char *stage, int rc, const WgError *err, const char *xml,
                          size_t len)
{
    if (rc == WG_OK) return false;
    if (!err) { /* the caller asked for no details: only the status */
        snprintf(last_error, sizeof last_error, "status %d (no WgError)", rc);
        if (rc > 0) report(st, stage, xml, len, "status %d", rc);
        return true;
    }
    char *buf = last_error;
    wg_error_format(err, buf, sizeof last_error);
    if (verbose) printf("fuzz: %ld %s: %s\n", current_index, stage, buf);
    if (rc > 0 || !err->message[0] || err->line < 0 || err->code != rc)
        report(st, stage, xml, len, "status %d, err.code %d, line %d, message '%s'", rc, err->code,
               err->line, buf);
    return true;
}

/* Whether a pixel node (here or in a subgraph) may write NaN or infinity. */
static bool may_be_nonfinite(const WgGraph *g)
{
    for (int i = 0; i < g->n_nodes; i++) {
        const NodeDef *n = &g->nodes[i];
        if (n->sub && may_be_nonfinite(n->sub)) return true;
        if (!n->type || strcmp(n->type->name, "pixel")) continue;
        for (int k = 0; k < n->n_attrs; k++) {
            const AttrDef *a = &n->attrs[k];
            if (!strcmp(a->name, "allow_nonfinite") &&
                (a->expr || a->ref_param >= 0 || a->literal.num != 0))
                return true;
        }
    }
    return false;
}

static long plan_pixels(const WgRequest *r)
{
    WgPlan plan;
    WgError err = {0};
    if (wg__plan_build(r, &plan, &err)) return -1;
    long px = 0;
    for (int i = 0; i < plan.n_insts; i++) px += (long)plan.insts[i].width * plan.insts[i].height;
    wg__plan_free(&plan);
    return px;
}

static void check_outputs(Stats *st, const WgResult *res, bool finite, const char *xml, size_t len)
{
    for (int i = 0; i < wg_result_output_count(res); i++) {
        const WgImage *img = wg_result_output_image(res, i);
        if (!img) {
            report(st, "render", xml, len, "output '%s' has no image",
                   wg_result_output_name(res, i));
            continue;
        }
        bool bad = false;
        for (int y = 0; y < img->height && finite && !bad; y++)
            for (int x = 0; x < img->width * img->channels && !bad; x++) {
                float v = wg_image_row(img, y)[x];
                if ((bad = !isfinite(v)))
                    report(st, "render", xml, len, "output '%s' holds %g at x=%d y=%d",
                           wg_result_output_name(res, i), v, x / img->channels, y);
            }
    }
}

static bool same_results(const WgResult *a, const WgResult *b)
{
    if (wg_result_output_count(a) != wg_result_output_count(b)) return false;
    for (int i = 0; i < wg_result_output_count(a); i++) {
        const WgImage *x = wg_result_output_image(a, i), *y = wg_result_output_image(b, i);
        if (x->width != y->width || x->height != y->height || x->channels != y->channels)
            return false;
        for (int r = 0; r < x->height; r++)
            if (memcmp(wg_image_row(x, r), wg_image_row(y, r),
                       sizeof(float) * (size_t)x->width * (size_t)x->channels))
                return false;
    }
    return true;
}

typedef struct {
    WgEngine *e1, *e2, *tight; /* 1 and 2 threads; 1 thread with a budget of a few images */
    WgEngine *disk;            /* 2 threads and a disk cache that is kept between mutants */
    WgImage *gray, *color;
    const char *path;
} Env;

/* Load, check and render one graph; returns the first failing status (WG_OK if it rendered,
 * or was only checked because it is too big to render). `choice` varies the request. */
static int run_one(Env *env, Stats *st, const char *xml, size_t len, uint64_t choice)
{
    current_xml = xml;
    current_len = len;
    alarm(120);
    WgError err_storage;
    memset(&err_storage, 0, sizeof err_storage);
    /* every API call accepts a NULL WgError; some mutants run that way */
    WgError *err = (choice >> 28 & 15) == 0 ? NULL : &err_storage;
    WgGraph *g = NULL;
    /* an exact copy, not NUL-terminated and freed once loaded: the loader must read only
     * [xml, xml + len) and keep nothing of it */
    char *exact = malloc(len + !len);
    assert_non_null(exact);
    memcpy(exact, xml, len);
    int rc = wg_graph_load_memory(exact, len, env->path, &g, err);
    free(exact);
    if (clean_failure(st, "load", rc, err, xml, len)) goto out;
    st->loaded++;
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    static const int sizes[][2] = {{8, 8}, {8, 8}, {8, 8}, {8, 8}, {4, 4}, {5, 3}, {1, 1}, {3, 7}};
    wg_request_set_size(r, sizes[choice & 7][0], sizes[choice & 7][1]);
    if (choice >> 6 & 1) wg_request_set_time(r, 2.5);
    /* the rarer request settings live in the high bits, all 0 for the seeds and regressions */
    if ((choice >> 35 & 3) == 3) wg_request_set_seed(r, choice * 0x9E3779B97F4A7C15ULL);
    if (choice >> 37 & 4) {
        static const double times[] = {NAN, INFINITY, -1e300, 1e9};
        wg_request_set_time(r, times[choice >> 37 & 3]);
    }
    if ((choice >> 40 & 7) == 7) { /* only one output, or one that does not exist */
        int no = wg_graph_output_count(g);
        const char *name =
            choice >> 43 & 1 ? "nosuch"
                             : wg_graph_output_info(g, (int)((choice >> 44) % (uint64_t)no))->name;
        memset(&err_storage, 0, sizeof err_storage);
        int orc = wg_request_add_output(r, name, err);
        clean_failure(st, "add_output", orc, err, xml, len);
    }
    for (int i = 0; i < wg_graph_input_count(g) && !rc; i++) {
        const WgGraphInputInfo *in = wg_graph_input_info(g, i);
        if (in->has_default && (choice >> 7 & 3)) continue;
        if (!in->has_default && !(choice >> 9 & 7)) continue; /* leave required ones unset */
        memset(&err_storage, 0, sizeof err_storage);
        if ((choice >> 46 & 7) == 7) { /* a file: good, huge, NaN, not an image, missing */
            static const char *const files[] = {"fuzz.png",     "fuzz_gray16.png", "fuzz_huge.exr",
                                                "fuzz_nan.exr", "fuzz_bad.png",    "nosuch.png"};
            rc = wg_request_set_input_file(r, in->name, wgt_path(files[(choice >> 49) % 6]), err);
            if (clean_failure(st, "set_input_file", rc, err, xml, len)) rc = WG_OK;
        } else {
            rc = wg_request_set_input_image(r, in->name,
                                            in->kind == WG_COLOR ? env->color : env->gray, err);
            clean_failure(st, "set_input_image", rc, err, xml, len);
        }
    }
    if (!rc && wg_graph_param_count(g) && !(choice >> 12 & 7)) { /* override a parameter */
        const WgGraphParamInfo *p =
            wg_graph_param_info(g, (int)((choice >> 15) % (uint64_t)wg_graph_param_count(g)));
        memset(&err_storage, 0, sizeof err_storage);
        int prc = wg_request_set(r, p->name, values[(choice >> 20) % N_VALUES], err);
        clean_failure(st, "set", prc, err, xml, len);
    }
    if (!rc) {
        memset(&err_storage, 0, sizeof err_storage);
        rc = wg_request_check(r, err);
        clean_failure(st, "check", rc, err, xml, len);
    }
    if (!rc) {
        st->checked++;
        long px = plan_pixels(r);
        if (px < 0) {
            report(st, "plan", xml, len, "the plan fails to build after a passing check");
        } else if (px > MAX_RENDER_PIXELS) {
            st->too_big++;
        } else {
            WgResult *res = NULL;
            memset(&err_storage, 0, sizeof err_storage);
            bool tight = (choice >> 32 & 7) == 7, disk = !tight && (choice >> 52 & 15) == 15;
            WgEngine *e = tight ? env->tight : disk ? env->disk : env->e1;
            rc = wg_render(e, r, &res, err);
            if (!clean_failure(st, "render", rc, err, xml, len)) {
                st->rendered++;
                check_outputs(st, res, !may_be_nonfinite(g), xml, len);
                if (choice >> 25 & 1 || disk) { /* disk: a cached result equals a fresh one */
                    WgResult *res2 = NULL;
                    memset(&err_storage, 0, sizeof err_storage);
                    int rc2 = wg_render(env->e2, r, &res2, err);
                    if (!clean_failure(st, "render (2 threads)", rc2, err, xml, len)) {
                        st->rendered2++;
                        if (!same_results(res, res2))
                            report(st, "render", xml, len, "two renders differ (threads or cache)");
                    }
                    wg_result_free(res2);
                    wg_engine_clear_cache(env->e2);
                }
            }
            wg_result_free(res);
            wg_engine_clear_cache(e); /* memory only: the disk cache stays */
        }
    }
    wg_request_free(r);
    wg_graph_free(g);
out:
    alarm(0);
    current_xml = NULL;
    return rc;
}

static uint64_t env_u64(const char *name, uint64_t def)
{
    const char *s = getenv(name);
    return s && *s ? strtoull(s, NULL, 0) : def;
}

static int setup(void **state)
{
    static Env env;
    wgt_write_file(wgt_path("fuzz_sub.wetgraph"), sub_xml);
    wgt_write_file(wgt_path("fuzz.wetgraph"), seeds[3]); /* type="fuzz": recursion */
    env.path = wgt_path("fuzz.wetgraph");
    env.e1 = wgt_engine(1, 256u << 20, NULL);
    env.e2 = wgt_engine(2, 256u << 20, NULL);
    env.tight = wgt_engine(1, 4096, NULL);
    env.disk = wgt_engine(2, 256u << 20, wgt_path("cache"));
    float g[16], c[64];
    for (int i = 0; i < 16; i++) g[i] = (float)i / 15;
    for (int i = 0; i < 64; i++) c[i] = (i & 3) == 3 ? 1.0f : (float)(i % 7) / 6;
    env.gray = wgt_image(4, 4, 1, g);
    env.color = wgt_image(4, 4, 4, c);
    /* image files for the `image` node: good ones, one with a NaN (found only when read), one
     * with values near FLT_MAX (infinite once decoded from sRGB), and one that is no image */
    WgError err = {0};
    float nan_px[16], huge_px[64];
    for (int i = 0; i < 16; i++) nan_px[i] = i == 5 ? NAN : 0.5f;
    for (int i = 0; i < 64; i++) huge_px[i] = i % 3 ? 3e38f : -3e38f;
    WgImage *nan_img = wgt_image(4, 4, 1, nan_px), *huge_img = wgt_image(4, 4, 4, huge_px);
    if (wg_image_write(wgt_path("fuzz.png"), env.color, WG_FORMAT_PNG, WG_LINEAR, &err) ||
        wg_image_write(wgt_path("fuzz_gray16.png"), env.gray, WG_FORMAT_PNG16, WG_LINEAR, &err) ||
        wg_image_write(wgt_path("fuzz_nan.exr"), nan_img, WG_FORMAT_EXR32, WG_LINEAR, &err) ||
        wg_image_write(wgt_path("fuzz_huge.exr"), huge_img, WG_FORMAT_EXR32, WG_LINEAR, &err))
        fail_msg("cannot write the test images: %s", err.message);
    wg_image_unref(nan_img);
    wg_image_unref(huge_img);
    wgt_write_file(wgt_path("fuzz_bad.png"), "\x89PNG\r\n\x1a\nnot really");
    signal(SIGALRM, on_alarm);
    keep_going = getenv("WGTEST_FUZZ_KEEP_GOING") != NULL;
    verbose = getenv("WGTEST_FUZZ_VERBOSE") != NULL;
    *state = &env;
    return 0;
}

static int teardown(void **state)
{
    Env *env = *state;
    wg_engine_free(env->e1);
    wg_engine_free(env->e2);
    wg_engine_free(env->tight);
    wg_engine_free(env->disk);
    wg_image_unref(env->gray);
    wg_image_unref(env->color);
    return 0;
}

/* ---- tests ------------------------------------------------------------------------------- */

static void test_seeds_render(void **state)
{
    Env *env = *state;
    Stats st = {0};
    for (int i = 0; i < N_SEEDS; i++) {
        current_index = -1 - i;
        /* every input given, default size: the seeds themselves must render */
        int rc = run_one(env, &st, seeds[i], strlen(seeds[i]),
                         (uint64_t)(1 | 7 << 9 | 1 << 12 | 1 << 28));
        if (rc) fail_msg("seed %d does not render (status %d)", i, rc);
    }
    assert_int_equal(st.rendered, N_SEEDS);
    assert_int_equal(st.bad, 0);
}

static void test_regressions(void **state)
{
    Env *env = *state;
    Stats st = {0};
    int count = 0;
    /* 8x8, an image for every input without a default (the others take theirs), no parameter
     * override, also rendered with 2 threads, with a WgError */
    const uint64_t choice = 1 << 7 | 1 << 9 | 1 << 12 | 1 << 25 | 1 << 28;
    for (int i = 0; regressions[i].name; i++, count++) {
        current_index = -100 - i;
        /* without a WgError first: the same status, and nothing written through NULL */
        int rc0 = run_one(env, &st, regressions[i].xml, strlen(regressions[i].xml),
                          choice & ~((uint64_t)15 << 28));
        if (rc0 != regressions[i].status)
            fail_msg("regression '%s' without a WgError: status %d, expected %d",
                     regressions[i].name, rc0, regressions[i].status);
        int rc = run_one(env, &st, regressions[i].xml, strlen(regressions[i].xml), choice);
        if (rc != regressions[i].status)
            fail_msg("regression '%s': status %d, expected %d", regressions[i].name, rc,
                     regressions[i].status);
        if (regressions[i].needle && !strstr(last_error, regressions[i].needle))
            fail_msg("regression '%s': expected '%s' in: %s", regressions[i].name,
                     regressions[i].needle, last_error);
    }
    printf("fuzz: %d regression graphs\n", count);
    assert_int_equal(st.bad, 0);
}

/* An input file that disappears between the request and the check (a race no graph can pin). */
static void test_input_file_vanishes(void **state)
{
    (void)state;
    const char *xml = "<wetgraph version=\"1\" size=\"$h\">\n"
                      "  <input name=\"h\" type=\"gray\"/>\n"
                      "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$h\"/></node>\n"
                      "  <output name=\"i\" from=\"i\"/>\n"
                      "</wetgraph>\n";
    WgGraph *g = wgt_load(xml);
    const char *path = wgt_path("vanishing.png");
    size_t n;
    char *png = wgt_read_file(wgt_path("fuzz_gray16.png"), &n);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(png, 1, n, f), n);
    fclose(f);
    free(png);
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_file(r, "h", path, &err), WG_OK);
    remove(path);
    /* the graph's size comes from the file, which is gone: NULL takes only the status */
    int rc = wg_request_check(r, NULL);
    assert_true(rc < 0);
    assert_int_equal(wg_request_check(r, &err), rc);
    assert_true(err.message[0] != '\0');
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_mutants(void **state)
{
    Env *env = *state;
    uint64_t seed = env_u64("WGTEST_FUZZ_SEED", DEFAULT_SEED);
    long count = (long)env_u64("WGTEST_FUZZ_COUNT", DEFAULT_COUNT);
    const char *dump = getenv("WGTEST_FUZZ_DUMP");
    rng_state = seed ? seed : 1;
    Stats st = {0};
    Buf b = {0};
    for (long m = 0; m < count; m++) {
        current_index = m;
        const char *s = seeds[below(N_SEEDS)];
        buf_set(&b, s, strlen(s));
        int steps = below(8) < 5 ? 1 : below(2) ? 2 : 1 + (int)below(8);
        for (int k = 0; k < steps; k++) mutate_once(&b);
        uint64_t choice = rnd();
        if (dump) {
            FILE *f = fopen(dump, "wb");
            if (f) {
                fwrite(b.p, 1, b.n, f);
                fclose(f);
            }
        }
        st.mutants++;
        if ((choice >> 45 & 7) == 7) { /* the mutant as a subgraph, read from its file */
            static const char wrapper[] =
                "<wetgraph version=\"1\" size=\"8\">\n"
                "  <node id=\"m\" type=\"fuzz_mut\" seed=\"3\" size=\"/2\"/>\n"
                "  <output name=\"o\" from=\"m\"/>\n"
                "</wetgraph>\n";
            FILE *f = fopen(wgt_path("fuzz_mut.wetgraph"), "wb");
            assert_non_null(f);
            fwrite(b.p, 1, b.n, f);
            fclose(f);
            current_sub = b.p;
            run_one(env, &st, wrapper, strlen(wrapper), choice);
            current_sub = NULL;
        } else {
            run_one(env, &st, b.p, b.n, choice);
        }
    }
    free(b.p);
    printf("fuzz: seed 0x%llx, %ld mutants: %ld loaded, %ld checked, %ld rendered (%ld also with "
           "2 threads), %ld too big to render, %ld bad\n",
           (unsigned long long)seed, st.mutants, st.loaded, st.checked, st.rendered, st.rendered2,
           st.too_big, st.bad);
    assert_int_equal(st.bad, 0);
    /* the mutants must reach every stage, or the fuzzer tests little */
    assert_true(st.loaded > count / 20);
    assert_true(st.rendered > count / 40);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_seeds_render),
        cmocka_unit_test(test_regressions),
        cmocka_unit_test(test_input_file_vanishes),
        cmocka_unit_test(test_mutants),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
