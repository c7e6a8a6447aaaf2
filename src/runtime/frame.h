/* frame.h - one frame as the runtime draws it: its size, camera and background.
 *
 * The runtime interface (runtime.h: runtime_render) takes a render_desc, and so
 * do the GL drawing modules (gpu/render.h, glrt.h). It lives here, apart from
 * any GL header, so that the library and its runtime build without GL
 * (make NO_GL=1). The camera is camera.h's; the background is a probe seen
 * through it, rotated as the light (probe_to_cube's R). */
#ifndef PRT_FRAME_H
#define PRT_FRAME_H
#include "camera.h"
#include "common.h"
#include "probe.h"

typedef struct render_desc {
    int width, height;           /* 0: 800 x 600 */
    prt_camera camera;
    const prt_probe *background; /* may be NULL */
    const float *background_rotation; /* 3x3 applied to the probe (as in probe_to_cube), may be NULL */
    bool direct_only;            /* GL runtime (glrt_render_image): light with the file's direct-only set */
    int samples;                 /* antialiasing: samples per pixel, multisampled and averaged in linear
                                  * radiance (0 or 1: one per pixel; at most what the GL context allows) */
} render_desc;
#endif
