/* prt_normalize.h - a .prt file compared but for its timings (test_resume, test_shard).
 *
 * Two precomputes of the same inputs differ only in their measured times and in the numbers the
 * plan prints (durations, sizes, thread counts); these tests compare everything else byte for byte. */
#ifndef PRT_TEST_NORMALIZE_H
#define PRT_TEST_NORMALIZE_H
#include "harness.h"
#include "prtfile.h"
#include "vmf.h"
#include <ctype.h>
#include <stdio.h>
#include <string.h>

/* The file dir/name with its timings zeroed and the plan's digits blanked, written again to
 * name.norm and read back as bytes (malloc'd; NULL on failure). */
static char *prt_normalized(const char *dir, const char *name, size_t *len) {
    char p[1024], q[1100];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    snprintf(q, sizeof q, "%s.norm", p);
    prt_data d;
    prt_error err;
    if (prtfile_read(p, &d, &err)) { CHECK(false, "%s", err.msg); return NULL; }
    prt_stats *s = &d.stats;
    s->t_brdf = s->t_visibility = s->t_transport = s->t_write = s->t_total = 0;
    memset(s->t_bounce, 0, sizeof s->t_bounce);
    s->peak_rss_bytes = 0;
    for (int i = 0; i < d.scene.nmaterials; i++) d.factors[i].seconds = 0;
    for (int i = 0; i < d.ntransfers; i++) {   /* the vmf transfer's pass and lobe-fit times */
        if (strcmp(d.transfers[i].ops->name, "vmf") != 0) continue;
        vmft_data *t = (vmft_data *)vmft_get(&d.transfers[i]);
        memset(t->t_pass, 0, sizeof t->t_pass);
        for (int m = 0; m < PRT_MAX_MATERIALS; m++) t->fit[m].seconds = 0;
    }
    char *w = d.plan;   /* each number (durations, sizes) becomes one '#' */
    for (const char *c = d.plan; *c; c++)
        if (!isdigit((unsigned char)*c) && !(*c == '.' && isdigit((unsigned char)c[1]))) *w++ = *c;
        else if (w == d.plan || w[-1] != '#') *w++ = '#';
    *w = 0;
    for (char *t; (t = strstr(d.plan, "threads"));) memmove(t + 6, t + 7, strlen(t + 7) + 1);   /* the count said */
    int rc = prtfile_write(q, &d, &err);
    prt_data_free(&d);
    if (rc) { CHECK(false, "%s", err.msg); return NULL; }
    return check_read_file(q, len);
}
#endif
