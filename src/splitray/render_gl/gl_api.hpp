#pragma once
// OpenGL 4.5 core entry points, linked directly from libOpenGL (GLVND).
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
