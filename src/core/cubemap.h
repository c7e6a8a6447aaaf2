/* cubemap.h - the global-frame cube map that lighting and transport live on.
 *
 * Faces follow OpenGL's cube-map convention (+X, -X, +Y, -Y, +Z, -Z; GL 4.6
 * spec table 8.19) so the GPU path can sample the same layout. Texel (i, j) of
 * face f is at index f*res*res + j*res + i; its centre has face coordinates
 * sc = 2(i+0.5)/res - 1, tc = 2(j+0.5)/res - 1, and its direction is
 *   +X: ( 1, -tc, -sc)   -X: (-1, -tc,  sc)
 *   +Y: ( sc,  1,  tc)   -Y: ( sc, -1, -tc)
 *   +Z: ( sc, -tc,  1)   -Z: (-sc, -tc, -1)
 * normalized. The lighting resolution is 64 (24,576 texels); visibility is
 * ray cast at 128 and box-filtered 2x2 (section 4.1).
 *
 * Solid angles are exact (the area formula of a gnomonic square), so they sum
 * to 4 pi to float precision (tested). Everything here is pure and thread-safe. */
#ifndef PRT_CUBEMAP_H
#define PRT_CUBEMAP_H
#include "common.h"

#define CUBE_RES 64
#define CUBE_TEXELS (6 * CUBE_RES * CUBE_RES)   /* 24,576: the length of a light or transport vector */

/* Unit direction at continuous face coordinates (x, y) in texel units: x = i + 0.5 is texel i's centre. */
void cube_dir(int res, int face, float x, float y, float dir[3]);
/* Texel centre direction of linear index idx. */
void cube_texel_dir(int res, int idx, float dir[3]);
/* Face and continuous texel coordinates (x, y in [0,res]) of a nonzero direction. */
void cube_lookup(int res, const float dir[3], int *face, float *x, float *y);
/* Linear texel index containing dir. */
int cube_texel_index(int res, const float dir[3]);
/* Exact solid angle of texel (i, j) (the same on every face). */
double cube_texel_solid_angle(int res, int i, int j);
/* Fills out[res*res] with the per-texel solid angles of one face (same for all six). */
void cube_face_solid_angles(int res, float *out);
#endif
