/* image.c - the pixel buffers of image.h: allocation and release, apart from the OpenImageIO
 * input and output of image_oiio.cpp so that images made in memory need no OpenImageIO. */
#include "image.h"
#include <stdlib.h>
#include <string.h>

/* Zeroed w x h x c image (c 3 or 4); 0, or -1 with err (bad size, OOM). image_free frees it. */
int image_alloc(prt_image *im, int w, int h, int c, prt_error *err) {
    memset(im, 0, sizeof *im);
    if (w <= 0 || h <= 0 || (c != 3 && c != 4)) return prt_fail(err, "bad image size %dx%dx%d", w, h, c);
    if ((long long)w * h > IMAGE_MAX_PIXELS) return prt_fail(err, "image %dx%d too large", w, h);
    im->data = prt_calloc((size_t)w * (size_t)h * (size_t)c, sizeof(float), err);
    if (!im->data) return -1;
    im->w = w;
    im->h = h;
    im->c = c;
    return 0;
}

/* Frees the pixels and zeroes the image (NULL is fine). */
void image_free(prt_image *im) {
    if (!im) return;
    free(im->data);
    memset(im, 0, sizeof *im);
}
