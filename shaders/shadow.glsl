// Soft contact shadows under every agent, one instanced draw: a floor quad
// per agent darkening with a radial falloff (blended, no depth write).
#include "common.glsl"

#ifdef VERTEX_SHADER
in vec2 in_corner;  // [-1, 1]^2

uniform sampler2D u_discs;  // row i: (x, y, radius, visible) of agent i

out vec2 v_local;
void main() {
    int eye = gl_InstanceID % u_eyes;
    int agent = gl_InstanceID / u_eyes;
    vec4 d = texelFetch(u_discs, ivec2(0, agent), 0);
    float r = d.z * 1.6 * d.w;
    vec3 world = vec3(d.x + in_corner.x * r, 0.004, d.y + in_corner.y * r);
    v_local = in_corner;
    gl_Position = eye_clip(world, eye);
}
#endif

#ifdef FRAGMENT_SHADER
in vec2 v_local;
out vec4 f_color;
void main() {
    float r = length(v_local);
    float a = 0.45 * (1.0 - smoothstep(0.35, 1.0, r));
    f_color = vec4(0.0, 0.0, 0.0, a);
}
#endif
