// Static environment: floor, walls and obstacles extruded from the scene
// polygons, the red target sphere. Vertex colours are linear RGB; the
// floor (u_pattern = 1) gets a 1 m grid, which helps judge distance in VR.
#include "common.glsl"

#ifdef VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in vec3 in_color;

uniform mat4 u_model;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;
flat out int v_eye;

void main() {
    int eye = gl_InstanceID % u_eyes;
    vec4 world = u_model * vec4(in_pos, 1.0);
    v_world = world.xyz;
    v_normal = mat3(u_model) * in_normal;
    v_color = in_color;
    v_eye = eye;
    gl_Position = eye_clip(v_world, eye);
}
#endif

#ifdef FRAGMENT_SHADER
in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;
flat in int v_eye;
out vec4 f_color;

uniform int u_pattern;
uniform vec3 u_emissive;
uniform float u_alpha;

void main() {
    vec3 albedo = v_color;
    if (u_pattern == 1) {
        // Anti-aliased 1 m grid lines and a faint 0.5 m checker.
        vec2 g = v_world.xz;
        vec2 w = fwidth(g);
        vec2 line = abs(fract(g - 0.5) - 0.5) / max(w, 1e-4);
        float grid = 1.0 - clamp(min(line.x, line.y) - 0.5, 0.0, 1.0);
        float checker = mod(floor(g.x * 2.0) + floor(g.y * 2.0), 2.0);
        albedo *= 0.92 + 0.08 * checker;
        albedo = mix(albedo, albedo * 0.55, grid * 0.8);
    }
    if (u_shadow_pass) { f_color = vec4(1.0); return; }
    vec3 c = shade(albedo, v_normal, v_world, u_eye_pos[v_eye]) + u_emissive;
    f_color = encode_output(c, u_alpha);
}
#endif
