// The crowd: skinned characters, one instanced draw per character, level of detail and piece
// of the mesh (issue 16, DESIGN.md "render"; skinning.glsl says which agent an instance draws).
// Vertices carry up to four bones and weights, two shape offsets (sex, build), a region for the
// materials; the renderer draws each agent's always-worn piece and the hair style and skirt it
// wears (pedvr/render/crowd.py draw_plan), so no vertex runs for pieces it does not wear.
#include "common.glsl"
#include "skinning.glsl"

#ifdef VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in vec3 in_dsex;
in vec3 in_dbuild;
in uvec4 in_bones;
in vec4 in_weights;
in int in_region;
in float in_t;
in vec3 in_local;
in float in_ao;
in vec2 in_uv;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_local;
out vec2 v_uv;
out float v_t;
out float v_ao;
flat out int v_region;
flat out int v_agent;
flat out int v_eye;

void main() {
    int eye = gl_InstanceID % u_eyes;
    int agent = instance_agent(u_eyes);
    v_agent = agent;
    v_eye = eye;
    v_region = in_region;
    v_t = in_t;
    v_ao = in_ao;
    v_uv = in_uv;
    v_local = in_local;
    skin(agent, in_pos, in_normal, in_dsex, in_dbuild, in_bones, in_weights, in_region, in_local, v_world,
         v_normal);
    gl_Position = eye_clip(v_world, eye);
}
#endif

#ifdef FRAGMENT_SHADER
in vec3 v_world;
in vec3 v_normal;
in vec3 v_local;
in vec2 v_uv;
in float v_t;
in float v_ao;
flat in int v_region;
flat in int v_agent;
flat in int v_eye;
out vec4 f_color;

uniform sampler2D u_albedo;  // avatars' base colour texture (TEXTURED region)
uniform vec4 u_base_color;   // avatars' base colour factor (linear)

const vec3 EYE_WHITE = vec3(0.82, 0.79, 0.75);
const vec3 PUPIL = vec3(0.008);
const float IRIS = 0.53;   // rad from the eye's axis: a 12.5 mm iris on the 24 mm eyeball
const float PUPIL_R = 0.2; // rad
const float SKIN_ROUGHNESS = 0.38;  // Beckmann m of skin (shade_skin)
const float LIPS_ROUGHNESS = 0.28;  // lips are smoother and moister
// The lips (pedvr/render/bodymesh.py body_prims): segments in the bind pose (x ≥ 0 half) and radii.
const vec3 UPPER_LIP_A = vec3(0.0, 1.5835, 0.1045), UPPER_LIP_B = vec3(0.022, 1.582, 0.1015);
const vec3 LOWER_LIP_A = vec3(0.0, 1.5715, 0.102), LOWER_LIP_B = vec3(0.019, 1.5735, 0.0995);
const vec2 UPPER_LIP_R = vec2(0.0052, 0.0022), LOWER_LIP_R = vec2(0.0064, 0.0024);  // middle, corner
const vec3 MOUTH_A = vec3(0.0, 1.5772, 0.1098), MOUTH_B = vec3(0.0205, 1.5778, 0.1032);

// Lips: the skin darker and redder (more so on light skin, whose lips show their blood more).
vec3 lips(vec3 skin) { return skin * vec3(0.78, 0.55, 0.53) + vec3(0.03, 0.005, 0.006); }

float segment_distance(vec3 p, vec3 a, vec3 b) {
    vec3 ab = b - a;
    float h = clamp(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0);
    return length(p - a - ab * h);
}

// The top's neckline: the height (bind pose, m) above which the trunk is bare at bind-pose x, z.
// Lower in front (a crew neck), and rising steeply beside the neck so that the shoulders stay
// covered whatever the seams (issue 25 item 18: skin showed in patches on the shoulders).
float neckline(float x, float z) {
    float r = abs(x) / 0.085;
    return 1.455 - 0.035 * smoothstep(0.0, 0.07, z) + 0.05 * r * r;
}

// Distance from a cone from `a` (radius ra) to `b` (radius rb) (the axis' nearest point's radius).
float cone_distance(vec3 p, vec3 a, vec3 b, float ra, float rb) {
    vec3 ab = b - a;
    float h = clamp(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0);
    return length(p - a - ab * h) - mix(ra, rb, h);
}

void main() {
    vec3 skin = look(v_agent, 0).rgb;
    vec3 albedo = skin;
    float spec = 0.0;
    float skin_m = SKIN_ROUGHNESS;  // > 0: shaded as skin (shade_skin) with this roughness
    if (v_region == TRUNK || v_region == ARM || v_region == LEG) {
        // One clothable body, cut along its arm and leg seams (bodymesh._cut_seams): the region is
        // flat, each triangle wholly on one side. v_local.z: the fraction along the limb (linear,
        // so a sleeve or trouser hem is a plane across it); v_t: the bind-pose height (the shirt
        // hem, a plane round the trunk); v_uv: the bind-pose z and x (the neckline).
        if (v_region == ARM) {
            if (v_local.z < look(v_agent, 0).a) {
                albedo = look(v_agent, 1).rgb;
                skin_m = 0.0;
            }
        } else if (v_region == LEG) {
            if (v_local.z > 0.955) {
                albedo = look(v_agent, 3).rgb;
                spec = 0.15;
                skin_m = 0.0;
            } else if (v_local.z < look(v_agent, 1).a) {
                albedo = look(v_agent, 2).rgb;
                skin_m = 0.0;
            }
        } else if (v_t > neckline(v_uv.y, v_uv.x)) {
            vec3 q = vec3(abs(v_uv.y), v_t, v_uv.x);
            if (segment_distance(q, vec3(0.012, 1.661, 0.098), vec3(0.052, 1.658, 0.085)) < 0.0082) {
                albedo = mix(skin, look(v_agent, 4).rgb, 0.85);  // brows
                skin_m = 0.0;
            } else {
                // Lips: each half of each lip a cone tapering from the middle to the corner
                // (bodymesh.body_prims), coloured within 3 mm of it, the edge blended over 1 mm.
                float d = min(min(cone_distance(q, UPPER_LIP_A, UPPER_LIP_B, UPPER_LIP_R.x, UPPER_LIP_R.y),
                                  cone_distance(q, LOWER_LIP_A, LOWER_LIP_B, LOWER_LIP_R.x, LOWER_LIP_R.y)),
                              0.01);
                float w = 1.0 - smoothstep(0.003, 0.004, d);
                // Where the lips meet: a thin dark line from the middle to the corners.
                float slit = 1.0 - smoothstep(0.0006, 0.0013, segment_distance(q, MOUTH_A, MOUTH_B));
                albedo = mix(skin, lips(skin), max(w, slit)) * (1.0 - 0.55 * slit);
                skin_m = mix(SKIN_ROUGHNESS, LIPS_ROUGHNESS, w);
            }
        } else {
            albedo = v_t > look(v_agent, 2).a ? look(v_agent, 1).rgb : look(v_agent, 2).rgb;
            skin_m = 0.0;
        }
    } else if (v_region == SKIRT) {
        albedo = look(v_agent, 2).rgb;
        skin_m = 0.0;
    } else if (v_region == HAIR) {
        vec3 h = look(v_agent, 4).rgb;
        // Strands: fine streaks running down from the crown (v_local: the bind-pose position).
        float around = atan(v_local.x, v_local.z + 0.01);
        albedo = h * (0.88 + 0.12 * sin(around * 150.0) + 0.08 * sin(around * 47.0));
        spec = 0.2;
        skin_m = 0.0;
    } else if (v_region == LIPS) {
        albedo = lips(skin);
        skin_m = LIPS_ROUGHNESS;
    } else if (v_region == BROW) {
        albedo = mix(skin, look(v_agent, 4).rgb, 0.85);
        skin_m = 0.0;
    } else if (v_region == LID_UPPER || v_region == LID_LOWER) {
        albedo = v_t < 0.09 ? mix(vec3(0.01), skin, smoothstep(0.03, 0.09, v_t)) : skin;
    } else if (v_region == EYE) {
        vec3 d = normalize(v_local);
        float ang = acos(clamp(d.z, -1.0, 1.0));
        vec3 iris = look(v_agent, 5).rgb;
        albedo = EYE_WHITE;
        if (ang < IRIS) {
            float r = ang / IRIS;
            albedo = mix(iris * (0.8 + 0.4 * r), iris * 0.35, smoothstep(0.85, 1.0, r));  // dark limbal ring
            albedo = mix(PUPIL, albedo, smoothstep(PUPIL_R - 0.03, PUPIL_R + 0.02, ang));
        }
        spec = 0.9;
        skin_m = 0.0;
    } else if (v_region == TEXTURED) {
        skin_m = 0.0;
        vec4 tex = texture(u_albedo, v_uv);
        if (tex.a < 0.5) discard;
        albedo = pow(tex.rgb, vec3(2.2)) * v_local * u_base_color.rgb;  // v_local: the base colour factor
    }
    vec3 eye_pos = u_eye_pos[v_eye];
    vec3 c = skin_m > 0.0 ? shade_skin(albedo, v_normal, v_world, eye_pos, v_ao, skin_m)
                          : shade_lit(albedo, v_normal, v_world, eye_pos, v_ao, spec);
    f_color = encode_output(c, 1.0);
}
#endif
