// Static environment: floor and markings, walls and obstacles extruded from the scene
// polygons, door leaves, the ceiling, the route target. Vertex colours are linear RGB;
// each material (pedvr/render/environment.py) gets a simple procedural texture from
// in_uv (metres along a wall and up it; ground x, y on caps; across and along a marking).
// The floor's pattern is u_floor (grid, tiles, wood, carpet, asphalt, paving); the grid's
// 1 m lines help judge distance in VR.
#include "common.glsl"

const int PAINT = 0, FLOOR = 1, PLASTER = 2, GLASS = 3, WOOD = 4, FACADE = 5, FABRIC = 6, ASPHALT = 7,
          MARKING = 8, CONCRETE = 9, METAL = 10, CEILING = 11;

#ifdef VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in vec3 in_color;
in vec2 in_uv;
in int in_material;

uniform mat4 u_model;

out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;
out vec2 v_uv;
flat out int v_material;
flat out int v_eye;

void main() {
    int eye = gl_InstanceID % u_eyes;
    vec4 world = u_model * vec4(in_pos, 1.0);
    v_world = world.xyz;
    v_normal = mat3(u_model) * in_normal;
    v_color = in_color;
    v_uv = in_uv;
    v_material = in_material;
    v_eye = eye;
    gl_Position = eye_clip(v_world, eye);
}
#endif

#ifdef FRAGMENT_SHADER
in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;
in vec2 v_uv;
flat in int v_material;
flat in int v_eye;
out vec4 f_color;

uniform int u_pattern;   // 1: the floor pass (floor and markings)
uniform int u_floor;     // the floor's pattern
uniform vec3 u_emissive;
uniform float u_alpha;

float hash2(vec2 p) { return fract(sin(dot(p, vec2(127.1, 311.7))) * 43758.5453); }

float noise2(vec2 p) {
    vec2 i = floor(p), f = fract(p);
    vec2 u = f * f * (3.0 - 2.0 * f);
    return mix(mix(hash2(i), hash2(i + vec2(1, 0)), u.x), mix(hash2(i + vec2(0, 1)), hash2(i + vec2(1, 1)), u.x), u.y);
}

// Anti-aliased lines of width `w` (in cells) every 1 cell.
float lines(vec2 g, float w) {
    vec2 fw = max(fwidth(g), vec2(1e-4));
    vec2 d = abs(fract(g - 0.5) - 0.5);
    vec2 l = 1.0 - smoothstep(vec2(w) - fw, vec2(w) + fw, d);
    return max(l.x, l.y);
}

vec3 floor_albedo(vec3 base, vec2 g) {
    if (u_floor == 1) {  // tiles: 0.6 m with grout, each tile a little different
        vec2 t = g / 0.6;
        float v = 0.9 + 0.1 * hash2(floor(t));
        return mix(base * v, base * 0.55, lines(t, 0.02));
    } else if (u_floor == 2) {  // wood: 0.15 m planks, staggered joints, grain
        vec2 t = vec2(g.x / 0.15, g.y / 1.2);
        float row = floor(t.x);
        float v = 0.8 + 0.25 * hash2(vec2(row, floor(t.y + 0.37 * row)));
        float grain = 0.92 + 0.08 * noise2(vec2(g.x * 40.0, g.y * 3.0));
        vec3 wood = vec3(0.42, 0.26, 0.14) * v * grain;
        return mix(wood, wood * 0.5, lines(vec2(t.x, 0.0), 0.03));
    } else if (u_floor == 3) {  // carpet: fine fleck
        return base * (0.85 + 0.15 * noise2(g * 60.0));
    } else if (u_floor == 4) {  // asphalt
        return vec3(0.05, 0.05, 0.055) * (0.8 + 0.4 * noise2(g * 8.0)) + 0.02 * noise2(g * 90.0);
    } else if (u_floor == 5) {  // paving: 0.4 × 0.2 m stones in a running bond
        vec2 t = vec2(g.x / 0.4, g.y / 0.2);
        t.x += 0.5 * mod(floor(t.y), 2.0);
        float v = 0.85 + 0.15 * hash2(floor(t));
        return mix(base * v, base * 0.5, lines(t, 0.04));
    }
    // grid: anti-aliased 1 m lines and a faint 0.5 m checker
    float checker = mod(floor(g.x * 2.0) + floor(g.y * 2.0), 2.0);
    vec3 a = base * (0.92 + 0.08 * checker);
    return mix(a, a * 0.55, lines(g, 0.02) * 0.8);
}

void main() {
    if (u_shadow_pass) { f_color = vec4(1.0); return; }
    vec3 albedo = v_color;
    vec3 n = normalize(v_normal);
    float ao = 1.0;
    float spec = 0.0;
    float vertical = 1.0 - abs(n.y);
    if (vertical > 0.5) {
        ao = mix(0.7, 1.0, smoothstep(0.0, 0.35, v_world.y));  // a touch of occlusion where walls meet the floor
    }
    if (v_material == FLOOR) {
        albedo = floor_albedo(v_color, v_world.xz);
    } else if (v_material == PLASTER) {
        albedo *= 0.95 + 0.05 * noise2(v_uv * 7.0);
        albedo = mix(albedo, albedo * 0.6, step(v_world.y, 0.1) * vertical);  // skirting board
    } else if (v_material == GLASS) {
        // Dark glass reflecting the sky more at grazing angles, with mullions every 1.2 m.
        vec3 v = normalize(u_eye_pos[v_eye] - v_world);
        float fres = 0.15 + 0.6 * pow(1.0 - max(dot(v, n), 0.0), 3.0);
        albedo = mix(v_color, SKY * 0.6, fres);
        albedo = mix(albedo, vec3(0.18), lines(vec2(v_uv.x / 1.2, 0.0), 0.025));
        spec = 1.0;
    } else if (v_material == WOOD) {
        float grain = 0.85 + 0.15 * noise2(vec2(v_uv.x * 3.0, v_uv.y * 40.0));
        albedo *= grain;
    } else if (v_material == FACADE) {
        // Storeys of 3.2 m: a glazed ground floor, then windows 1.4 m wide every 2.4 m.
        vec2 c = vec2(v_uv.x / 2.4, v_uv.y / 3.2);
        vec2 f = fract(c);
        bool window = v_world.y > 4.0 && vertical > 0.5 && abs(f.x - 0.5) < 0.29 && f.y > 0.3 && f.y < 0.85;
        if (v_world.y < 3.6 && vertical > 0.5) {
            window = v_world.y > 0.3 && abs(fract(v_uv.x / 3.0) - 0.5) < 0.44;
        }
        float tone = 0.9 + 0.1 * hash2(floor(c));
        if (window) {
            vec3 v = normalize(u_eye_pos[v_eye] - v_world);
            float fres = 0.25 + 0.5 * pow(1.0 - max(dot(v, n), 0.0), 2.0);
            albedo = mix(vec3(0.05, 0.07, 0.09) + 0.06 * hash2(floor(c) + 3.1), SKY * 0.7, fres);
            spec = 0.8;
        } else {
            albedo *= tone * (0.93 + 0.07 * noise2(v_uv * 3.0));
        }
    } else if (v_material == FABRIC) {
        albedo *= 0.9 + 0.1 * noise2(v_uv * 50.0);
    } else if (v_material == MARKING) {
        // Zebra bars 0.5 m deep every metre along the crossing (bars across the way, stepped over
        // one by one); the road shows between them. The paint is worn a little: thinner in
        // patches and scuffed finely, but never through to the road (holes punched where a noise
        // fell below a threshold read as black blotches: issue 25 item 17).
        if (fract(v_uv.y) < 0.5) discard;
        float worn = smoothstep(0.6, 0.95, noise2(v_world.xz * 2.5)) * (0.4 + 0.6 * noise2(v_world.xz * 35.0));
        albedo *= (0.9 + 0.1 * noise2(v_world.xz * 20.0)) * (1.0 - 0.22 * worn);
    } else if (v_material == CONCRETE) {
        albedo *= 0.88 + 0.12 * noise2(v_uv * 5.0);
    } else if (v_material == METAL) {
        spec = 0.6;
    } else if (v_material == CEILING) {
        // Ceiling tiles of 0.6 m with a light panel every 2.4 m.
        vec2 t = v_uv / 0.6;
        albedo = mix(albedo, albedo * 0.7, lines(t, 0.015));
        vec2 p = fract(v_uv / 2.4);
        if (all(lessThan(abs(p - 0.5), vec2(0.13)))) {
            f_color = encode_output(vec3(1.0, 0.98, 0.93), u_alpha);
            return;
        }
    }
    vec3 c = shade_lit(albedo, n, v_world, u_eye_pos[v_eye], ao, spec) + u_emissive;
    f_color = encode_output(c, u_alpha);
}
#endif
