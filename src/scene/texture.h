/* texture.h - base-colour textures: the albedo a model's file paints on its diffuse lobe.
 *
 * Usage:
 *     scene_texture t; prt_error err;
 *     if (texture_from_image(&t, "wood.png", &img, &err)) ...      // from image_read's linear floats
 *     float rgb[3]; texture_sample(&t, u, v, rgb);                   // linear RGB at (u, v)
 *     texture_mean_triangle(&t, uv, rgb);                            // mean over a triangle's UVs
 *     texture_free(&t);
 *
 * A texture holds 8-bit sRGB texels (what PNG and JPEG base-colour maps store, and what a .prt file
 * keeps: prtfile.h) and their linear values (the sRGB curve, IEC 61966-2-1), which every sample
 * reads. The glTF 2.0 specification makes baseColorTexture sRGB; MTL map_Kd maps are taken as sRGB
 * too (what image editors write). A linear float image is encoded to sRGB bytes (clamped to [0, 1]:
 * an albedo), so an 8-bit file comes back texel for texel.
 *
 * Coordinates: (u, v) with v up, as assimp hands them for every format (it flips glTF's
 * top-down v), so texel row 0, the image's top, is v = 1. Sampling is bilinear between texel
 * centres with repeat wrapping (glTF's default sampler), the rule of the GL runtimes' samplers
 * too, so the CPU, the raster and `prt reference` agree. texture_mean_triangle averages the
 * texture over a triangle in UV space (equal-area samples, as many as the texels it covers, 16 to
 * 4096): the albedo interreflection passes use for light leaving a triangle. Ownership: the
 * texture owns its arrays (texture_free). */
#ifndef PRT_TEXTURE_H
#define PRT_TEXTURE_H
#include "common.h"

#define TEXTURE_MAX_SIDE 16384

typedef struct scene_texture {
    char name[128];     /* the file, or "MODEL.glb image N" for an embedded one */
    int w, h;
    uint8_t *srgb;      /* [h][w][3] 8-bit sRGB, row 0 at the top (v = 1) */
    float *lin;         /* [h][w][3] their linear values */
} scene_texture;

struct prt_image;
/* From linear RGB floats (image.h; 3 or 4 channels, alpha dropped). 0, or -1 with err naming name. */
int texture_from_image(scene_texture *t, const char *name, const struct prt_image *im, prt_error *err);
/* From w x h sRGB bytes (copied). 0, or -1 with err (a size outside 1..TEXTURE_MAX_SIDE, out of memory). */
int texture_from_srgb(scene_texture *t, const char *name, int w, int h, const uint8_t *srgb, prt_error *err);
void texture_free(scene_texture *t);
/* Linear RGB at (u, v): bilinear, repeat. Non-finite coordinates read texel (0, 0). */
void texture_sample(const scene_texture *t, float u, float v, float rgb[3]);
/* Mean linear RGB over the triangle with corner coordinates uv[6] (u0 v0 u1 v1 u2 v2). */
void texture_mean_triangle(const scene_texture *t, const float uv[6], float rgb[3]);
#endif
