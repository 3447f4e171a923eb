"""A small ``main`` that runs an exported model or controller on a log read from standard input.

The text read is whitespace-separated numbers (decimal or C99 hexadecimal, ``nan``, ``inf``):
the number of rows ``n``, then ``n`` rows. A model's row is its inputs then its outputs
(``NAME_N_INPUTS + NAME_N_OUTPUTS`` values; the outputs are read for the first
``NAME_INITIAL_ROWS`` rows only, the others may be anything); the log is preprocessed
(``NAME_preprocess``), the first ``NAME_INITIAL_ROWS`` rows reset the model, and every other row
is stepped, printing its outputs (with ``step_bounds``: then the lower and upper bounds) as
``%a`` (exact hexadecimal) on one line. A controller's row is ``reference measurement``; each
step prints the command. ``neckid export --to c --driver`` writes it as ``NAME_main.c``::

    cc -O2 -std=c99 NAME.c NAME_main.c -lm -o run && ./run < log.txt
"""

from __future__ import annotations

from neckid.export.c.program import CModel

__all__ = ["driver_source"]

_MODEL = r"""/* Runs NAME on a log read from standard input (see NAME.h); prints each step's outputs. */
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

static int read_number(double *value)
{
    char text[64];
    if (scanf("%63s", text) != 1) return 0;
    *value = strtod(text, NULL);
    return 1;
}

int main(void)
{
    double count;
    size_t n, t, k;
    double *u, *y, out[NAME_N_OUTPUTS + 2 * NAME_N_OUTPUTS];
    NAME_state s;
    if (!read_number(&count) || count < 0) return 2;
    n = (size_t)count;
    u = malloc((n + 1) * NAME_N_INPUTS * sizeof *u);
    y = malloc((n + 1) * NAME_N_OUTPUTS * sizeof *y);
    if (u == NULL || y == NULL) return 3;
    for (t = 0; t < n; ++t) {
        for (k = 0; k < NAME_N_INPUTS; ++k)
            if (!read_number(&u[t * NAME_N_INPUTS + k])) return 2;
        for (k = 0; k < NAME_N_OUTPUTS; ++k)
            if (!read_number(&y[t * NAME_N_OUTPUTS + k])) return 2;
    }
    if (NAME_preprocess(n, u, y) != 0) return 4;
    if (NAME_INITIAL_ROWS > 0 && n >= NAME_INITIAL_ROWS) {
        size_t first = NAME_INITIAL_ROWS - NAME_RESET_ROWS;
        NAME_reset(&s, y + first * NAME_N_OUTPUTS, u + first * NAME_N_INPUTS);
    } else {
        NAME_init(&s);
    }
    for (t = NAME_INITIAL_ROWS; t < n; ++t) {
@STEP@
        for (k = 0; k < @WIDTH@; ++k) printf(k ? " %a" : "%a", out[k]);
        printf("\n");
    }
    free(u);
    free(y);
    return 0;
}
"""

_CONTROLLER = r"""/* Runs NAME on reference and measurement rows read from standard input; prints commands. */
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

static int read_number(double *value)
{
    char text[64];
    if (scanf("%63s", text) != 1) return 0;
    *value = strtod(text, NULL);
    return 1;
}

int main(void)
{
    double count, reference, measurement;
    size_t n, t;
    NAME_state s;
    if (!read_number(&count) || count < 0) return 2;
    n = (size_t)count;
    NAME_init(&s);
    for (t = 0; t < n; ++t) {
        if (!read_number(&reference) || !read_number(&measurement)) return 2;
        printf("%a\n", NAME_step(&s, reference, measurement));
    }
    return 0;
}
"""


def driver_source(model: CModel, name: str) -> str:
    """The driver's C source for ``model`` exported as ``name``."""
    if model.controller:
        return _CONTROLLER.replace("NAME", name)
    if model.bounded:
        step = (
            "        NAME_step_bounds(&s, u + t * NAME_N_INPUTS, out, out + NAME_N_OUTPUTS,"
            " out + 2 * NAME_N_OUTPUTS);"
        )
        width = "3 * NAME_N_OUTPUTS"
    else:
        step = "        NAME_step(&s, u + t * NAME_N_INPUTS, out);"
        width = "NAME_N_OUTPUTS"
    text = _MODEL.replace("@STEP@", step).replace("@WIDTH@", width)
    return text.replace("NAME", name)
