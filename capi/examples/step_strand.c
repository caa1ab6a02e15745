/*
 * One curly hair strand of N = 5 elements through the superhelix C API.
 *
 *   step_strand             hangs from a still head under gravity (0, 0, -9.81)
 *   step_strand release     no gravity: released from 1.03 x its natural curvature
 *   step_strand unchecked   as the first, with the plain step (no checks after the fact)
 *   step_strand tolerance T as the first (or with release), with error-controlled steps
 *                           at tolerance T: each strand chooses its own steps within
 *                           every 1/30 s
 *
 * Either way it takes 30 steps of 1/30 s and prints the parameters it made, q after the
 * last step and the centreline (world coordinates), one value per line:
 *
 *   frame <i> <value>      root frame, column-major (n0, n1, n2)
 *   natural <i> <value>    natural (tau, kappa1, kappa2) of every element
 *   q <i> <value>          q after the last step
 *   point <i> <x> <y> <z>  element end i, root first
 *   steps 0 <n>            with a tolerance: steps taken in all (and `rejected 0 <n>`,
 *                          `largest_error 0 <e>`, the largest estimated error / length)
 *
 * Build (from the workspace root, after cargo build -p superhelix-capi --release):
 *
 *   cc -std=c99 -Icapi/include capi/examples/step_strand.c \
 *      target/release/libsuperhelix_capi.a -lpthread -ldl -lm -o step_strand
 */
#include "superhelix.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N 5
#define D (3 * N)
#define PI 3.14159265358979323846

/* Prints what failed and returns from main with 1. */
#define CHECK(call)                                                                        \
    do {                                                                                   \
        ShStatus status_ = (call);                                                         \
        if (status_ != SH_STATUS_OK) {                                                     \
            fprintf(stderr, "%s: %s\n", #call, sh_status_message(status_));                \
            if (batch != NULL) {                                                           \
                ShError error_;                                                            \
                if (sh_batch_last_error(batch, &error_) == SH_STATUS_OK &&                 \
                    error_.message[0] != '\0') {                                           \
                    fprintf(stderr, "  %s\n", error_.message);                             \
                }                                                                          \
            }                                                                              \
            sh_batch_free(batch);                                                          \
            return 1;                                                                      \
        }                                                                                  \
    } while (0)

int main(int argc, char **argv) {
    ShBatch *batch = NULL;
    int release = 0, checked = 1;
    double tolerance = 0.0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "release") == 0) {
            release = 1;
        } else if (strcmp(argv[i], "unchecked") == 0) {
            checked = 0;
        } else if (strcmp(argv[i], "tolerance") == 0 && i + 1 < argc) {
            tolerance = strtod(argv[++i], NULL);
        } else {
            fprintf(stderr, "usage: step_strand [release] [unchecked] [tolerance T]\n");
            return 2;
        }
    }

    /* root frame: n0 along (0.3, 0, -1), n1 the x axis made orthogonal to it,
       n2 = n0 x n1 */
    double n0[3] = {0.3, 0.0, -1.0};
    double len0 = sqrt(n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]);
    for (int i = 0; i < 3; i++) n0[i] /= len0;
    double n1[3] = {1.0 - n0[0] * n0[0], -n0[0] * n0[1], -n0[0] * n0[2]};
    double len1 = sqrt(n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]);
    for (int i = 0; i < 3; i++) n1[i] /= len1;
    double n2[3] = {n0[1] * n1[2] - n0[2] * n1[1], n0[2] * n1[0] - n0[0] * n1[2],
                    n0[0] * n1[1] - n0[1] * n1[0]};

    /* natural shape of a helix of radius 6 mm and step 5 mm (exact helix formula) */
    double radius = 6e-3, step = 5e-3;
    double c = step / (2.0 * PI);
    double den = radius * radius + c * c;
    double tau = c / den, kappa = radius / den;

    ShStrandParams params;
    memset(&params, 0, sizeof params);
    params.elements = N;
    params.length = 0.2;
    params.element_lengths = NULL; /* N equal elements */
    for (int i = 0; i < 3; i++) {
        params.root_frame[i] = n0[i];
        params.root_frame[3 + i] = n1[i];
        params.root_frame[6 + i] = n2[i];
    }
    params.cross_section.radius = 50e-6;
    params.cross_section.ellipticity = 1.0;
    params.cross_section.youngs_modulus = 1.5e9;
    params.cross_section.poisson_ratio = 0.48;
    params.cross_section.density = 1300.0;
    params.natural[0] = tau; /* twist first */
    params.natural[1] = kappa;
    params.natural[2] = 0.0;
    params.natural_per_element = NULL; /* the same on every element */
    params.internal_friction = 5e-11;
    params.air_drag = 5e-6;

    ShError error;
    ShStatus status = sh_batch_new(&params, 1, &batch, &error);
    if (status != SH_STATUS_OK) {
        fprintf(stderr, "sh_batch_new: %s\n  %s\n", sh_status_message(status), error.message);
        return 1;
    }

    CHECK(sh_batch_set_checked(batch, checked));
    if (tolerance > 0.0) {
        CHECK(sh_batch_set_tolerance(batch, tolerance));
    }
    ShHeadState head;
    CHECK(sh_head_rest(&head)); /* a still head at the origin */
    CHECK(sh_batch_set_head(batch, &head));
    if (release) {
        double q0[D];
        size_t written = 0;
        CHECK(sh_batch_state(batch, 0, q0, NULL, D, &written));
        for (int i = 0; i < D; i++) q0[i] *= 1.03;
        CHECK(sh_batch_set_state(batch, 0, q0, NULL, D));
        CHECK(sh_batch_set_gravity(batch, NULL));
    } else {
        const double gravity[3] = {0.0, 0.0, -9.81};
        CHECK(sh_batch_set_gravity(batch, gravity));
    }

    double largest_rotation = 0.0, largest_error = 0.0;
    size_t substeps = 0, steps = 0, rejected = 0;
    for (int k = 0; k < 30; k++) {
        CHECK(sh_batch_step(batch, 1.0 / 30.0));
        ShStepReport report;
        CHECK(sh_batch_last_step(batch, &report));
        if (report.max_element_rotation > largest_rotation) {
            largest_rotation = report.max_element_rotation;
        }
        substeps += report.substeps;
        steps += report.steps;
        rejected += report.rejected;
        if (report.largest_error > largest_error) {
            largest_error = report.largest_error;
        }
    }

    double q[D], qdot[D], points[3 * (N + 1)];
    size_t written = 0, written_points = 0, strand_bytes = 0, workspace_bytes = 0;
    CHECK(sh_batch_state(batch, 0, q, qdot, D, &written));
    CHECK(sh_batch_centreline(batch, 0, points, N + 1, &written_points));
    CHECK(sh_strand_bytes(N, &strand_bytes));
    CHECK(sh_workspace_bytes(N, &workspace_bytes));

    printf("# %s, %s step, N = %d, 30 steps of 1/30 s; largest element rotation %.3g rad, "
           "%zu substeps\n",
           release ? "release without gravity" : "hanging under gravity",
           tolerance > 0.0 ? "error-controlled" : checked ? "checked" : "plain", N,
           largest_rotation, substeps);
    printf("# %zu bytes per strand, %zu per workspace\n", strand_bytes, workspace_bytes);
    for (int i = 0; i < 9; i++) printf("frame %d %.17g\n", i, params.root_frame[i]);
    for (int i = 0; i < 3; i++) printf("natural %d %.17g\n", i, params.natural[i]);
    for (size_t i = 0; i < written; i++) printf("q %zu %.17g\n", i, q[i]);
    for (size_t i = 0; i < written_points; i++) {
        printf("point %zu %.17g %.17g %.17g\n", i, points[3 * i], points[3 * i + 1],
               points[3 * i + 2]);
    }
    if (tolerance > 0.0) {
        printf("steps 0 %zu\nrejected 0 %zu\nlargest_error 0 %.17g\n", steps, rejected,
               largest_error);
    }
    sh_batch_free(batch);
    return 0;
}
