/* image.h - float RGB(A) images read and written through OpenImageIO.
 *
 * OpenImageIO speaks C++ only; src/image/image_oiio.cpp wraps it behind this C
 * header (image_read, image_write) and is the only C++ in prt. The pixel buffers
 * (image_alloc, image_free) are plain C in image.c, so code that only makes images
 * in memory (the fuzz harnesses, linked without OpenImageIO) needs none of it.
 *
 * Usage:
 *     prt_image im; prt_error err;
 *     if (image_read("city.exr", &im, &err)) puts(err.msg);
 *     image_desc d = { .exposure = 0 };                 // zero means defaults
 *     if (image_write("out.png", &im, &d, &err)) puts(err.msg);
 *     image_free(&im);
 *
 * image_read returns linear float pixels (any format OIIO reads: EXR, HDR,
 * PFM, PNG...; 8-bit formats are converted from sRGB to linear), always 3
 * channels (grey is replicated, alpha dropped). Rows top to bottom.
 *
 * image_write picks the format from the extension: .exr writes linear 32-bit
 * float (half for .exr with d.half) RGB, .hdr linear Radiance RGBE;
 * .png/.jpg/.tif/.ppm write 8-bit sRGB after
 * exposure (2^exposure) and the tone map (d.tonemap: 0 clamp, 1 Reinhard,
 * 2 ACES fit; default clamp). Non-finite pixels are written as 0. The image is encoded in
 * memory, then written to a temporary name with every write, the flush and the close
 * checked (a full disk is an error, for every format), and renamed, so no partial file
 * is left behind and no message names the temporary.
 *
 * Errors: one line naming the file (missing, unreadable, unsupported format,
 * zero size, a failed write). Ownership: data belongs to the image; image_free frees it. */
#ifndef PRT_IMAGE_H
#define PRT_IMAGE_H
#include "common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct prt_image {
    int w, h, c;     /* c is 3 (RGB) or 4 (RGBA) */
    float *data;     /* [h][w][c], row 0 at the top */
    bool ldr;        /* image_read: the file stores integers (PNG, JPEG, 8/16-bit TIFF...), so every
                      * value is in [0, 1]: a light probe's sun clipped to the sky's white */
} prt_image;

typedef struct image_desc {
    float exposure;  /* stops, for 8-bit output */
    int tonemap;     /* 0 clamp, 1 Reinhard, 2 ACES */
    bool half;       /* EXR: half floats */
} image_desc;

/* Largest image accepted (pixels): keeps a crafted header from asking for terabytes; 2^28 RGB
 * float pixels is 3 GiB. */
#define IMAGE_MAX_PIXELS (1LL << 28)

int image_alloc(prt_image *im, int w, int h, int c, prt_error *err);
int image_read(const char *path, prt_image *out, prt_error *err);
/* image_read of an image file's bytes buf[len] (an image embedded in a .glb); name stands for the
 * file in errors and gives the format by its extension ("car.glb#image0.png"). */
int image_read_memory(const char *name, const void *buf, size_t len, prt_image *out, prt_error *err);
int image_write(const char *path, const prt_image *im, const image_desc *desc, prt_error *err);
void image_free(prt_image *im);
/* Whether image_write writes path as 8-bit sRGB (its extension: png, jpg, tif, ppm), where the
 * exposure and the tone map apply; else linear floats (exr, hdr). */
bool image_tonemapped(const char *path);

#ifdef __cplusplus
}
#endif
#endif
