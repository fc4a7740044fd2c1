// The crowd in the key light's shadow map: depth only (issue 27). The same skinning as the views
// (skinning.glsl) without anything the views' shading needs: no normals, no varyings, no colour.
// The renderer draws it at each character's coarsest level within two of the map's texels of the
// finest (pedvr/render/crowd.py shadow_level: at 2048 texels over 32 m, 1.6 cm each, filtered over
// 3×3 taps 1.5 texels apart, the procedural character's coarsest, 1.9 cm from its finest).
#include "skinning.glsl"

uniform mat4 u_light_vp;

#ifdef VERTEX_SHADER
in vec3 in_pos;
in vec3 in_dsex;
in vec3 in_dbuild;
in uvec4 in_bones;
in vec4 in_weights;
in int in_region;
in vec3 in_local;

void main() {
    vec3 world, unused;
    skin(instance_agent(1), in_pos, vec3(0.0), in_dsex, in_dbuild, in_bones, in_weights, in_region, in_local,
         world, unused);
    gl_Position = u_light_vp * vec4(world, 1.0);
}
#endif

#ifdef FRAGMENT_SHADER
void main() {}
#endif
