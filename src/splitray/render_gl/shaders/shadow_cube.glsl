// Included (before shadow.frag.glsl) by the point lights' cube-map variant of pass 1 only:
// a shader that writes gl_FragDepth on some path leaves the depth undefined on the others.
#define SHADOW_CUBE 1
