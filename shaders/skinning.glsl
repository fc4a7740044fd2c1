// Skinning shared by the crowd's programs (crowd.glsl draws the views, crowd_depth.glsl the key
// light's shadow map; issue 16, DESIGN.md "render"). Instance k of a draw is agent
// u_order[u_order_row][u_base + k / eyes], seen by eye k % eyes (pedvr/render/crowd.py draw_plan:
// each draw is one piece of the mesh, for the agents that wear it). Agent i's skinning matrices
// are row i of u_skin (three texels per bone: the rows of M = [s·R | p − s·R·r], crowd.py
// skin_rows); its looks are row i of u_looks (crowd.py look_rows).

// Regions (pedvr/render/bodymesh.py).
const int SKIN = 0, TRUNK = 1, ARM = 2, LEG = 3, FOOT = 4, EYE = 5, LID_UPPER = 6, LID_LOWER = 7,
          HAIR = 8, SKIRT = 9, LIPS = 10, BROW = 11, TEXTURED = 12;

uniform sampler2D u_skin;
uniform sampler2D u_looks;
uniform isampler2D u_order;
uniform int u_base;
uniform int u_order_row;

vec4 look(int agent, int k) { return texelFetch(u_looks, ivec2(k, agent), 0); }

#ifdef VERTEX_SHADER
const float LID_CLOSE_UPPER = 0.80;  // rad the upper lid turns down to shut (24° above the axis to 22° below)
const float LID_CLOSE_LOWER = 0.06;  // rad the lower lid rises

// The agent this instance draws when each agent is drawn `eyes` times in a row.
int instance_agent(int eyes) {
    return texelFetch(u_order, ivec2(u_base + gl_InstanceID / eyes, u_order_row), 0).r;
}

mat3x4 bone_rows(int agent, int b) {
    return mat3x4(texelFetch(u_skin, ivec2(3 * b, agent), 0), texelFetch(u_skin, ivec2(3 * b + 1, agent), 0),
                  texelFetch(u_skin, ivec2(3 * b + 2, agent), 0));
}

vec3 xform(mat3x4 m, vec4 p) { return vec3(dot(m[0], p), dot(m[1], p), dot(m[2], p)); }

// Rotation about the x axis by a (decreases the angle above the z axis by a).
vec3 rot_x(vec3 v, float a) {
    float c = cos(a), s = sin(a);
    return vec3(v.x, c * v.y - s * v.z, s * v.y + c * v.z);
}

// A bind-pose vertex (position `pos`, normal `n`, shape offsets, up to four bones, region, and
// `local`: a lid's pivot) of `agent` in the world: shaped by its sex and build, lids turned for
// its blink and its eyes' pitch, skinned. A caller that ignores `world_normal` pays nothing for it.
void skin(int agent, vec3 pos, vec3 n, vec3 dsex, vec3 dbuild, uvec4 bones, vec4 weights, int region,
          vec3 local, out vec3 world, out vec3 world_normal) {
    vec4 shape = look(agent, 6);
    vec3 p = pos + shape.x * dsex + shape.y * dbuild;
    if (region == LID_UPPER || region == LID_LOWER) {
        // Lids turn about the eye's centre: down to blink, and with the eye's pitch in the head.
        int eb = local.x > 0.0 ? 14 : 15;  // LEye, REye
        mat3x4 h = bone_rows(agent, 13), e = bone_rows(agent, eb);
        vec3 fwd = vec3(e[0].z, e[1].z, e[2].z);  // the eye's +Z in the world (times the scale)
        vec3 in_head = vec3(dot(vec3(h[0].x, h[1].x, h[2].x), fwd), dot(vec3(h[0].y, h[1].y, h[2].y), fwd),
                            dot(vec3(h[0].z, h[1].z, h[2].z), fwd));
        float pitch = asin(clamp(in_head.y / max(length(in_head), 1e-6), -1.0, 1.0));
        float blink = look(agent, 5).a;
        float a = region == LID_UPPER ? -0.75 * pitch + blink * LID_CLOSE_UPPER
                                      : -0.35 * pitch - blink * LID_CLOSE_LOWER;
        p = local + rot_x(p - local, a);
        n = rot_x(n, a);
    }
    vec4 hp = vec4(p, 1.0);
    world = vec3(0.0);
    world_normal = vec3(0.0);
    for (int k = 0; k < 4; ++k) {
        float w = weights[k];
        if (w > 0.0) {
            mat3x4 m = bone_rows(agent, int(bones[k]));
            world += w * xform(m, hp);
            world_normal += w * xform(m, vec4(n, 0.0));
        }
    }
}
#endif
