// SPDX-License-Identifier: MIT
// Two-layer wet shading for real-time engines: the model of the `preview` node (nodes/preview.c,
// docs/preview.md) as a GLSL 3.30 fragment shader. A water layer (its own height, normal,
// roughness and F0) lies over a metallic/roughness PBR material; the water reflects the
// environment, the view ray is refracted into it before the parallax search of the material
// below, which receives and returns light scaled by 1 − F and is seen through Beer–Lambert
// absorption (clear by default). Where water_mask is 0 the result is the one-layer shading of
// the material. The material under the water is shaded with its own metallic and specular
// level, a metal staying a metal. Ambient light is the split sum with multiple scattering
// restored (Fdez-Agüera 2019), for the material and the water alike, as in the preview.
//
// Material maps (GL_REPEAT, GL_LINEAR; uv in tiles, +v towards the top of the image):
//   basecolor (sRGB texture, so it samples linear), normal_map (OpenGL, green up, linear),
//   roughness, height (0..1, 1 is the tile plane), ao, metallic: the maps of wet_material
//   (`basecolor`, `ao`, `metallic`), with `under_height` as `height` and the material's own
//   normal and roughness under the water; specular (the specular level, F0 = 0.08 × specular
//   for dielectrics), read only where specular_from_map is true, else specular_level (0.5:
//   F0 0.04).
// Layer maps (wet_material's outputs of the same names): water_height (0..1), water_normal
//   (OpenGL), water_roughness, water_specular (F0, linear), water_mask (0..1).
// Lighting: prefiltered (an equirectangular map with a mip chain, level = roughness ×
//   prefiltered_levels, filtered with the GGX lobe per level: env_prefilter's blocks 0-5),
//   irradiance (equirectangular, irradiance / π), brdf_lut (split-sum table: u = n·v,
//   v = roughness, r = A, g = B). Directions are in tangent space, z up; the equirectangular
//   convention is env_prefilter's: u = 0.5 − φ / 2π (φ from +x towards +y), v = θ / π from the
//   zenith (rows stored top down, so t = 1 − v when the texture origin is at the bottom).
// Inputs from the vertex shader: uv, and view_ts, the direction from the surface towards the
// eye in tangent space (unnormalised). The result is linear radiance × 2^exposure, before any
// tone mapping (preview applies Narkowicz's ACES fit and sRGB encoding after this).
//
// Surfaces other than the flat tile (both off by default, so that the tile is shaded exactly as
// without them):
// - Curved surfaces: compiled with WG_TANGENT_FRAME defined (a line `#define WG_TANGENT_FRAME`
//   after the version line), the shader takes a third input, tangent_to_world (mat3; columns T
//   along +u, B along +v, N the outward normal, in world space, z up; orthonormalised here with
//   B = N × T), and the environment (and sun_dir, then a world direction) is read in world
//   space: tangent space is world space only for the flat tile. The parallax search and the
//   water's relief stay in tangent space, with the surface taken as flat around each point: on a
//   surface curved within a few relief depths (a small sphere, height_scale large) the relief is
//   only approximate, slipping at grazing angles and near the silhouette.
// - Displaced surfaces: with displaced true the mesh itself is raised to the top of the layers
//   (surface_top: the water's surface where water_mask > 0 and the water stands over the relief,
//   else the relief, height_scale × (top − 1) below the tile's plane, in the tile's flat frame),
//   so the view ray starts there rather than at the tile's plane: the dry relief is hit at once
//   (the parallax search adds nothing the mesh has not drawn), and under the water the refracted
//   ray is searched from the water's own surface, so the depth of water and its absorption are
//   the same as on the flat tile. The normal maps stay relative to the flat tile (they hold the
//   whole relief), so the mesh's own normals are not used. Relief finer than the mesh is drawn
//   flat (its shading, from the normal map, is kept).
#version 330 core

uniform sampler2D basecolor;
uniform sampler2D normal_map;
uniform sampler2D roughness;
uniform sampler2D height;
uniform sampler2D ao;
uniform sampler2D metallic;
uniform sampler2D specular;
uniform sampler2D water_height;
uniform sampler2D water_normal;
uniform sampler2D water_roughness;
uniform sampler2D water_specular;
uniform sampler2D water_mask;
uniform sampler2D prefiltered;
uniform sampler2D irradiance;
uniform sampler2D brdf_lut;

uniform float prefiltered_levels = 5.0;
uniform float height_scale = 0.04; // tile widths between height 1 and height 0
uniform int pom_steps = 48;
uniform float env_rotation = 0.0; // radians
uniform float exposure = 0.0;     // stops
uniform bool sun = false;
uniform vec3 sun_dir = vec3(0.0, 0.57, 0.82); // towards the sun, tangent space (world: WG_TANGENT_FRAME)
uniform vec3 sun_radiance = vec3(3.0);        // irradiance on a surface facing the sun
uniform float water_ior = 1.33;
uniform bool specular_from_map = false; // else specular_level everywhere
uniform float specular_level = 0.5;     // F0 = 0.08 × specular for dielectrics
uniform vec3 water_tint = vec3(1.0);    // transmittance over absorption_depth (clear)
uniform float absorption_depth = 1.0;           // height units
uniform bool displaced = false; // the mesh is raised to surface_top (see above)

in vec2 uv;
in vec3 view_ts;
#ifdef WG_TANGENT_FRAME
in mat3 tangent_to_world;
mat3 frame; // tangent_to_world orthonormalised, set by main
#endif
out vec4 frag_color;

const float PI = 3.141592653589793;

vec2 equirect(vec3 d)
{
#ifdef WG_TANGENT_FRAME
    d = frame * d;
#endif
    float phi = atan(d.y, d.x) + env_rotation;
    float u = fract(0.5 - phi / (2.0 * PI));
    float v = acos(clamp(d.z, -1.0, 1.0)) / PI;
    return vec2(u, 1.0 - v);
}

vec3 env_spec(vec3 d, float r) { return textureLod(prefiltered, equirect(d), r * prefiltered_levels).rgb; }
vec3 env_irr(vec3 n) { return texture(irradiance, equirect(n)).rgb; }
vec2 lut(float nv, float r) { return texture(brdf_lut, vec2(nv, r)).rg; }

// Fresnel reflectance f0 + (1 − f0)·w(c): w is the exact Fresnel curve of a dielectric of
// index 1.5 rescaled from 0 (normal incidence) to 1 (grazing), linear in f0 like Schlick's but
// rising as the real curve does (as the preview node, and its split-sum table, do).
float fresnel_w(float c)
{
    c = clamp(c, 0.0, 1.0);
    float g = sqrt(1.25 + c * c);
    float a = (g - c) / (g + c), b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return (0.5 * a * a * (1.0 + b * b) - 0.04) / 0.96;
}
const float W_AVG = 0.0539354; // 2 ∫ w(c) c dc: F_avg = f0 + (1 − f0)·W_AVG
float fresnel(float f0, float c) { return f0 + (1.0 - f0) * fresnel_w(c); }
vec3 fresnel3(vec3 f0, float c) { return f0 + (1.0 - f0) * fresnel_w(c); }
// The water's surface: the exact Fresnel curve of the index whose normal reflectance is f0,
// n = (1 + √f0)/(1 − √f0), for light crossing it at cos c on the air side (either way).
float water_fresnel(float f0, float c)
{
    float s = sqrt(clamp(f0, 0.0, 0.98)), n = (1.0 + s) / (1.0 - s);
    c = clamp(c, 1e-6, 1.0);
    float g = sqrt(n * n - 1.0 + c * c);
    float a = (g - c) / (g + c), b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
}

float vis_smith(float nv, float nl, float a)
{
    float a2 = a * a;
    float gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
    float gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
    return 0.5 / (gv + gl);
}

float ggx(float nh, float a)
{
    float a2 = a * a, d = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Ambient weights of a lobe of reflectance f0 with split-sum terms ab: single scattering
// fss = f0·A + B, and ms, the light a white lobe loses to masking (1 − A − B) returned after
// scattering between microfacets, leaving about as diffusely as the irradiance.
vec3 ms_term(vec3 f0, vec2 ab, vec3 fss)
{
    float ems = 1.0 - ab.x - ab.y;
    vec3 favg = f0 + (1.0 - f0) * W_AVG;
    return fss * favg / (1.0 - ems * favg) * ems;
}

vec3 decode_normal(vec3 c)
{
    vec3 n = normalize(c * 2.0 - 1.0);
    return n.z < 1e-3 ? normalize(vec3(n.xy, 1e-3)) : n;
}

// Parallax occlusion mapping: the first point where p + t d (d.z < 0) meets the surface
// z = height_scale (h − 1), searched from z_top down to z_bot (tile units, uv = p.xy).
vec3 march(sampler2D hmap, vec3 p, vec3 d, float z_top, float z_bot)
{
    if (height_scale <= 0.0) return p - d * (p.z / d.z);
    float t0 = p.z > z_top ? (z_top - p.z) / d.z : 0.0;
    float t1 = (z_bot - p.z) / d.z;
    if (t1 <= t0) return p + d * t0;
    float dt = (t1 - t0) / float(pom_steps);
    float prev_t = t0, prev_gap = 0.0;
    for (int i = 0; i <= pom_steps; i++) {
        float t = t0 + dt * float(i);
        vec3 q = p + d * t;
        float gap = q.z - height_scale * (texture(hmap, q.xy).r - 1.0);
        if (gap <= 0.0) {
            if (i == 0) return q;
            return p + d * (prev_t + dt * prev_gap / (prev_gap - gap));
        }
        prev_t = t;
        prev_gap = gap;
    }
    return p + d * t1;
}

// The relief standing out of the water, met by the water's mirror ray p + t d (d.z > 0) before
// it rises to the tile's plane: pom_steps steps and one secant step; the point in q.
bool relief_above(vec3 p, vec3 d, out vec3 q)
{
    q = p;
    if (d.z <= 1e-4 || height_scale <= 0.0 || p.z >= 0.0) return false;
    float dt = -p.z / d.z / float(pom_steps);
    float prev_gap = max(p.z - height_scale * (texture(height, p.xy).r - 1.0), 0.0);
    for (int i = 1; i <= pom_steps; i++) {
        vec3 s = p + d * (dt * float(i));
        float gap = s.z - height_scale * (texture(height, s.xy).r - 1.0);
        if (gap <= 0.0) {
            q = p + d * (dt * (float(i - 1) + prev_gap / (prev_gap - gap)));
            return true;
        }
        prev_gap = gap;
    }
    return false;
}

// The direction to read the prefiltered environment in for a lobe of roughness r around the
// mirror direction rd: Frostbite's dominant direction, leaning to the normal as the lobe widens.
vec3 dominant_dir(vec3 n, vec3 rd, float r)
{
    float a = r * r, f = (1.0 - a) * (sqrt(1.0 - a) + a);
    return normalize(mix(n, rd, f));
}

float radical_inverse(uint i)
{
    i = (i << 16u) | (i >> 16u);
    i = ((i & 0x55555555u) << 1u) | ((i & 0xAAAAAAAAu) >> 1u);
    i = ((i & 0x33333333u) << 2u) | ((i & 0xCCCCCCCCu) >> 2u);
    i = ((i & 0x0F0F0F0Fu) << 4u) | ((i & 0xF0F0F0F0u) >> 4u);
    i = ((i & 0x00FF00FFu) << 8u) | ((i & 0xFF00FF00u) >> 8u);
    return float(i) * 2.3283064365386963e-10;
}

// The gain of the diffuse colour under the water, 1/(1 − r_e)²: the base colour is the wet
// albedo seen from outside (Lekner and Dorf's, with the way through the surface in and out),
// and this path sends the light through the surface again both ways. r_e: the diffuse external
// reflectance of the index whose F0 is f0w, as the maps' model computes it.
float under_water_gain(float f0w)
{
    float s = sqrt(clamp(f0w, 0.0, 0.98)), n = (1.0 + s) / (1.0 - s);
    float ri = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
    float re = clamp(1.0 - n * n * (1.0 - ri), 0.0, 0.9);
    return 1.0 / ((1.0 - re) * (1.0 - re));
}

// Ambient irradiance over π at a point of normal n under a water surface of normal nw and F0
// f0w: each direction la above the surface, refracted to the water, scaled by 1 − F, reaching
// the point from the cone of refracted directions; 16 cosine-weighted Hammersley directions in
// the surface's frame, the light read from the prefiltered level of roughness 0.8.
const int UW_SAMPLES = 16;
vec3 under_irradiance(vec3 n, vec3 nw, float f0w)
{
    vec3 up = abs(nw.z) < 0.999 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 tx = normalize(cross(up, nw)), ty = cross(nw, tx);
    vec3 acc = vec3(0.0);
    for (int k = 0; k < UW_SAMPLES; k++) {
        float u1 = (float(k) + 0.5) / float(UW_SAMPLES), u2 = radical_inverse(uint(k));
        float rr = sqrt(u1), ph = 2.0 * PI * u2, cz = sqrt(1.0 - u1);
        vec3 la = tx * (rr * cos(ph)) + ty * (rr * sin(ph)) + nw * cz;
        vec3 t = refract(-la, nw, 1.0 / water_ior);
        float cw = -dot(t, nw), nl = -dot(t, n);
        if (nl > 0.0 && cw > 1e-4)
            acc += env_spec(la, 0.8) * ((1.0 - water_fresnel(f0w, cz)) * nl / cw);
    }
    return acc / float(UW_SAMPLES);
}

// Radiance leaving the material at uv towards v; sun_l / sun_rad the sun's direction and
// irradiance there. Under the water (submerged), the ambient light is what crosses the surface
// of normal nw and F0 f0w, and the reflection leaves through it scaled by 1 − F or, beyond the
// critical angle, sees the submerged floor (this point's own diffuse radiance).
vec3 shade(vec2 st, vec3 v, bool submerged, vec3 nw, float f0w, vec3 sun_l, vec3 sun_rad)
{
    vec3 base = clamp(texture(basecolor, st).rgb, 0.0, 1.0);
    vec3 n = decode_normal(texture(normal_map, st).rgb);
    float r = clamp(texture(roughness, st).r, 0.0, 1.0);
    float metal = clamp(texture(metallic, st).r, 0.0, 1.0);
    float occ = clamp(texture(ao, st).r, 0.0, 1.0);
    float level = specular_from_map ? clamp(texture(specular, st).r, 0.0, 1.0) : specular_level;
    float nv = clamp(dot(n, v), 1e-4, 1.0);
    vec3 f0 = mix(vec3(0.08 * level), base, metal);
    vec3 dc = base * (1.0 - metal) * (submerged ? under_water_gain(f0w) : 1.0);
    vec2 ab = lut(nv, r);
    vec3 fss = f0 * ab.x + ab.y;
    vec3 ms = ms_term(f0, ab, fss);
    vec3 e = fss + ms;
    vec3 rd = dominant_dir(n, reflect(-v, n), r);
    vec3 irr, rad;
    if (!submerged) {
        irr = env_irr(n);
        rad = env_spec(rd, r);
    } else {
        irr = under_irradiance(n, nw, f0w);
        vec3 ra = dot(rd, nw) > 0.0 ? refract(rd, -nw, water_ior) : vec3(0.0);
        if (ra != vec3(0.0))
            rad = env_spec(ra, r) * (1.0 - water_fresnel(f0w, dot(ra, nw)));
        else
            rad = irr * dc;
    }
    vec3 color = (rad * fss + irr * (ms + dc * (1.0 - e))) * occ;
    float nl = dot(n, sun_l);
    if (sun && nl > 0.0) {
        vec3 h = normalize(v + sun_l);
        float a = max(r * r, 2e-3);
        vec3 f = fresnel3(f0, clamp(dot(v, h), 0.0, 1.0));
        vec3 spec = f * ggx(clamp(dot(n, h), 0.0, 1.0), a) * vis_smith(nv, nl, a);
        color += (spec + dc * (1.0 - f) / PI) * sun_rad * nl;
    }
    return color;
}

// The top of the layers at st, the height a displaced mesh is raised to: the water's surface
// where there is water standing over the relief, else the relief.
float surface_top(vec2 st)
{
    float h = texture(height, st).r;
    return texture(water_mask, st).r > 0.0 ? max(h, texture(water_height, st).r) : h;
}

void main()
{
    vec3 sun_d = sun_dir;
#ifdef WG_TANGENT_FRAME
    vec3 fn = normalize(tangent_to_world[2]);
    vec3 ft = normalize(tangent_to_world[0] - fn * dot(fn, tangent_to_world[0]));
    frame = mat3(ft, cross(fn, ft), fn);
    sun_d = sun_dir * frame; // world to tangent space
#endif
    vec3 v = normalize(view_ts);
    vec3 d = -v;
    vec3 p = vec3(uv, 0.0);
    if (displaced) p.z = height_scale * (surface_top(uv) - 1.0);
    // the dry material (one layer)
    vec3 pd = march(height, p, d, 0.0, -height_scale);
    vec3 color = shade(pd.xy, v, false, vec3(0.0, 0.0, 1.0), 0.0, sun_d, sun_radiance);

    vec3 pw = march(water_height, p, d, 0.0, -height_scale);
    float m = clamp(texture(water_mask, pw.xy).r, 0.0, 1.0);
    if (m > 0.0) {
        vec3 nw = decode_normal(texture(water_normal, pw.xy).rgb);
        float rw = clamp(texture(water_roughness, pw.xy).r, 0.0, 1.0);
        float f0 = clamp(texture(water_specular, pw.xy).r, 0.0, 1.0);
        float nv = clamp(dot(nw, v), 1e-4, 1.0);
        vec2 ab = lut(nv, rw);
        float fss = f0 * ab.x + ab.y;
        float ms = ms_term(vec3(f0), ab, vec3(fss)).x;
        // the table follows the index-1.5 curve: scaled to the water's own at n·v
        float fc = fresnel(f0, nv), kf = fc > 1e-6 ? water_fresnel(f0, nv) / fc : 1.0;
        fss *= kf;
        ms *= kf;
        float e = min(fss + ms, 1.0); // the lobe's albedo: Fresnel's F(n·v) when smooth
        // the mirror image: the relief standing out of the water where the ray meets it, else
        // the environment
        vec3 rr = reflect(d, nw), q;
        vec3 mirror = relief_above(pw, rr, q)
                          ? shade(q.xy, -rr, false, vec3(0.0, 0.0, 1.0), 0.0, sun_d, sun_radiance)
                          : env_spec(dominant_dir(nw, rr, rw), rw);
        vec3 top = mirror * fss + env_irr(nw) * ms;
        vec3 sun_l = sun_d, sun_under = vec3(0.0);
        float nl = dot(nw, sun_d);
        if (sun && nl > 0.0) {
            vec3 h = normalize(v + sun_d);
            float a = max(rw * rw, 2e-3);
            top += sun_radiance * ggx(clamp(dot(nw, h), 0.0, 1.0), a) * vis_smith(nv, nl, a)
                   * water_fresnel(f0, clamp(dot(v, h), 0.0, 1.0)) * nl;
            sun_l = -refract(-sun_d, nw, 1.0 / water_ior);
            sun_under = sun_radiance * (1.0 - water_fresnel(f0, nl));
        }
        vec3 t = refract(d, nw, 1.0 / water_ior);
        if (t.z >= 0.0) t = d;
        vec3 pu = march(height, pw, t, pw.z, -height_scale);
        vec3 under = shade(pu.xy, -t, true, nw, f0, sun_l, sun_under);
        float path = height_scale > 0.0 ? (length(pw - pu) + max(pw.z - pu.z, 0.0)) / height_scale : 0.0;
        vec3 tr = pow(clamp(water_tint, 0.0, 1.0), vec3(path / absorption_depth));
        vec3 wet = top + under * tr * (1.0 - e);
        color = mix(color, wet, m);
    }
    frag_color = vec4(color * exp2(exposure), 1.0);
}
