// Shared by every 3D program (pulled in by the loader's include directive).
// Stereo: u_eyes is 1 (one view) or 2 (single-pass side-by-side: instance
// k draws for eye k % 2 into the left or right half of the target).
uniform mat4 u_view_proj[2];
uniform vec3 u_eye_pos[2];
uniform int u_eyes;
uniform bool u_srgb_encode;  // false when the target is an sRGB surface that encodes on write

const vec3 SKY = vec3(0.62, 0.74, 0.88);
const vec3 GROUND_BOUNCE = vec3(0.30, 0.27, 0.23);
const vec3 SUN_DIR = normalize(vec3(0.35, 0.85, 0.45));  // towards the sun
const vec3 SUN = vec3(1.05, 1.0, 0.92);
const float FOG_DENSITY = 0.012;  // per metre; distant things fade to the sky: a depth cue

#ifdef VERTEX_SHADER
// Clip position of a world point for eye `eye`; in side-by-side mode the
// image is squeezed into its half and a clip plane cuts it at the seam.
vec4 eye_clip(vec3 world, int eye) {
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
// Hemisphere ambient + one sun + distance fog, in linear light.
vec3 shade(vec3 albedo, vec3 n, vec3 world, vec3 eye) {
    n = normalize(n);
    float hemi = 0.5 + 0.5 * n.y;
    vec3 ambient = mix(GROUND_BOUNCE, SKY, hemi) * 0.55;
    float sun = max(dot(n, SUN_DIR), 0.0);
    vec3 c = albedo * (ambient + SUN * sun * 0.75);
    float d = length(world - eye);
    float fog = 1.0 - exp(-FOG_DENSITY * d);
    return mix(c, SKY, clamp(fog, 0.0, 1.0));
}

vec4 encode_output(vec3 linear_rgb, float alpha) {
    vec3 c = clamp(linear_rgb, 0.0, 1.0);
    if (u_srgb_encode) {
        c = mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
    }
    return vec4(c, alpha);
}
#endif
