// The whole crowd in one instanced draw (issue 4, DESIGN.md "render").
// Vertices belong to body segments; each names its bone and colour slot.
// Bone matrices (bone-local -> world, column-major, 4 RGBA32F texels per
// bone) of agent i are row i of u_bones; agent i's four clothing/skin
// colours are row i of u_palette. Instance k draws agent k / u_eyes for
// eye k % u_eyes.
#include "common.glsl"

#ifdef VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in int in_bone;
in int in_slot;

uniform sampler2D u_bones;
uniform sampler2D u_palette;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_albedo;
flat out int v_eye;

// Fixed colours of the slots that do not vary per agent (linear RGB).
const vec3 EYE_WHITE = vec3(0.92, 0.92, 0.90);
const vec3 PUPIL = vec3(0.01, 0.01, 0.012);

void main() {
    int eye = gl_InstanceID % u_eyes;
    int agent = gl_InstanceID / u_eyes;
    int b = in_bone * 4;
    mat4 bone = mat4(texelFetch(u_bones, ivec2(b, agent), 0), texelFetch(u_bones, ivec2(b + 1, agent), 0),
                     texelFetch(u_bones, ivec2(b + 2, agent), 0), texelFetch(u_bones, ivec2(b + 3, agent), 0));
    vec4 world = bone * vec4(in_pos, 1.0);
    v_world = world.xyz;
    v_normal = mat3(bone) * in_normal;
    if (in_slot < 4) {
        v_albedo = texelFetch(u_palette, ivec2(in_slot, agent), 0).rgb;
    } else {
        v_albedo = in_slot == 4 ? EYE_WHITE : PUPIL;
    }
    v_eye = eye;
    gl_Position = eye_clip(v_world, eye);
}
#endif

#ifdef FRAGMENT_SHADER
in vec3 v_world;
in vec3 v_normal;
in vec3 v_albedo;
flat in int v_eye;
out vec4 f_color;

void main() {
    f_color = encode_output(shade(v_albedo, v_normal, v_world, u_eye_pos[v_eye]), 1.0);
}
#endif
