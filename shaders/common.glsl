// Shared by every 3D program (pulled in by the loader's include directive).
// Stereo: u_eyes is 1 (one view) or 2 (single-pass side-by-side: instance
// k draws for eye k % 2 into the left or right half of the target).
// Shadow pass (u_shadow_pass): the same vertices go through the key light's
// orthographic view-projection u_light_vp into the shadow map (depth only);
// the crowd has a program of its own for it (crowd_depth.glsl).
uniform mat4 u_view_proj[2];
uniform vec3 u_eye_pos[2];
uniform int u_eyes;
uniform bool u_srgb_encode;  // false when the target is an sRGB surface that encodes on write
uniform bool u_shadow_pass;
uniform mat4 u_light_vp;
uniform bool u_shadows;      // sample the shadow map (false: everything lit by the key light)
uniform sampler2DShadow u_shadow_map;

const vec3 SKY = vec3(0.62, 0.74, 0.88);
const vec3 GROUND_BOUNCE = vec3(0.34, 0.31, 0.27);
const vec3 SUN_DIR = normalize(vec3(0.35, 0.85, 0.45));  // towards the key light (pedvr/render/lighting.py)
const vec3 SUN = vec3(1.0, 0.96, 0.88);
const vec3 FILL_DIR = normalize(vec3(-0.35, 0.35, -0.45));  // a soft fill opposite the key light
const vec3 FILL = vec3(0.30, 0.32, 0.36);
const float FOG_DENSITY = 0.012;  // per metre; distant things fade to the sky: a depth cue

#ifdef VERTEX_SHADER
// Clip position of a world point for eye `eye`; in side-by-side mode the
// image is squeezed into its half and a clip plane cuts it at the seam.
vec4 eye_clip(vec3 world, int eye) {
    if (u_shadow_pass) {
        gl_ClipDistance[0] = 1.0;
        return u_light_vp * vec4(world, 1.0);
    }
    vec4 clip = u_view_proj[eye] * vec4(world, 1.0);
    if (u_eyes == 2) {
        float side = eye == 0 ? -0.5 : 0.5;
        clip.x = clip.x * 0.5 + side * clip.w;
        gl_ClipDistance[0] = eye == 0 ? -clip.x : clip.x;
    } else {
        gl_ClipDistance[0] = 1.0;
    }
    return clip;
}
#endif

#ifdef FRAGMENT_SHADER
// Fraction of the key light reaching `world` (1 lit, 0 in shadow): 3×3 taps of hardware
// 2×2 percentage-closer filtering, looked up a little off the surface along its normal.
float key_light(vec3 world, vec3 n) {
    if (!u_shadows) return 1.0;
    float facing = dot(n, SUN_DIR);
    vec4 l = u_light_vp * vec4(world + n * (0.02 + 0.03 * (1.0 - abs(facing))), 1.0);
    vec3 c = l.xyz / l.w * 0.5 + 0.5;
    if (any(lessThan(c.xy, vec2(0.0))) || any(greaterThan(c.xy, vec2(1.0))) || c.z > 1.0) return 1.0;
    vec2 texel = 1.0 / vec2(textureSize(u_shadow_map, 0));
    float sum = 0.0;
    for (int i = -1; i <= 1; ++i) {
        for (int j = -1; j <= 1; ++j) {
            sum += texture(u_shadow_map, vec3(c.xy + vec2(i, j) * texel * 1.5, c.z - 0.0008));
        }
    }
    return sum / 9.0;
}

// The sky and ground as seen along direction `r`: the hemisphere ambient's radiance.
vec3 environment_radiance(vec3 r) {
    return mix(GROUND_BOUNCE, SKY, 0.5 + 0.5 * r.y) * 0.62;
}

// Distance fog: distant things fade to the sky (a depth cue).
vec3 fogged(vec3 c, vec3 world, vec3 eye) {
    float fog = 1.0 - exp(-FOG_DENSITY * length(world - eye));
    return mix(c, SKY, clamp(fog, 0.0, 1.0));
}

// Hemisphere ambient and a soft fill (times the ambient occlusion `ao`) and the key light with its
// shadow (`lit`, 0..1) on a Lambertian surface of `albedo` with normal `n` facing the viewer.
vec3 diffuse_lit(vec3 albedo, vec3 n, float ao, float ndl, float lit) {
    vec3 ambient = (environment_radiance(n) + FILL * max(dot(n, FILL_DIR), 0.0)) * ao;
    return albedo * (ambient + SUN * max(ndl, 0.0) * 0.95 * lit);
}

// Hemisphere ambient and a soft fill (times the ambient occlusion `ao`), the key light with its shadow,
// a touch of specular, distance fog; linear light.
vec3 shade_lit(vec3 albedo, vec3 n, vec3 world, vec3 eye, float ao, float spec) {
    n = normalize(n);
    vec3 v = normalize(eye - world);
    if (dot(n, v) < -0.2) n = -n;  // seen from inside (thin shells): light the side we see
    float ndl = dot(n, SUN_DIR);
    float lit = ndl > 0.0 ? key_light(world, n) : 0.0;
    vec3 c = diffuse_lit(albedo, n, ao, ndl, lit);
    if (spec > 0.0) {
        vec3 h = normalize(SUN_DIR + v);
        c += SUN * spec * 0.25 * pow(max(dot(n, h), 0.0), 48.0) * lit;
    }
    return fogged(c, world, eye);
}

// Skin (and lips): the diffuse light of shade_lit plus the reflection off the skin's surface, which
// every skin has whatever its melanin: a dielectric of F0 = 0.028 (refractive index 1.4) with a
// Beckmann roughness `m` (0.3-0.45 over a face: Weyrich et al. 2006, "Analysis of human faces using
// a measurement-based skin reflectance model"), the key light through the Kelemen/Szirmay-Kalos
// specular that d'Eon & Luebke use for real-time skin (GPU Gems 3, ch. 14), and the sky's and
// ground's sheen (the hemisphere's radiance in the mirror direction, Schlick's Fresnel damped by
// the roughness, times `ao`). On dark skin this reflection is most of what shows a face's form.
const float SKIN_F0 = 0.028;
vec3 shade_skin(vec3 albedo, vec3 n, vec3 world, vec3 eye, float ao, float m) {
    n = normalize(n);
    vec3 v = normalize(eye - world);
    if (dot(n, v) < -0.2) n = -n;
    float ndl = dot(n, SUN_DIR);
    float lit = ndl > 0.0 ? key_light(world, n) : 0.0;
    vec3 c = diffuse_lit(albedo, n, ao, ndl, lit);
    vec3 h = SUN_DIR + v;  // unnormalised: |h|² = 4 (v·ĥ)²
    float hh = max(dot(h, h), 1e-4);
    float ndh = max(dot(n, h), 0.0) * inversesqrt(hh);
    float vdh = 0.5 * sqrt(hh);
    if (ndl > 0.0 && ndh > 0.0) {
        float t2 = (1.0 - ndh * ndh) / (ndh * ndh);  // tan² of the half vector's angle
        float beckmann = exp(-t2 / (m * m)) / (3.14159265 * m * m * ndh * ndh * ndh * ndh);
        float fresnel = SKIN_F0 + (1.0 - SKIN_F0) * pow(1.0 - vdh, 5.0);
        c += SUN * 0.95 * lit * ndl * fresnel * beckmann / hh;
    }
    float ndv = clamp(dot(n, v), 0.0, 1.0);
    float f_env = SKIN_F0 + (max(1.0 - m, SKIN_F0) - SKIN_F0) * pow(1.0 - ndv, 5.0);
    c += f_env * environment_radiance(reflect(-v, n)) * ao;
    return fogged(c, world, eye);
}

vec3 shade(vec3 albedo, vec3 n, vec3 world, vec3 eye) {
    return shade_lit(albedo, n, world, eye, 1.0, 0.0);
}

vec4 encode_output(vec3 linear_rgb, float alpha) {
    vec3 c = clamp(linear_rgb, 0.0, 1.0);
    if (u_srgb_encode) {
        c = mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
    }
    return vec4(c, alpha);
}
#endif
