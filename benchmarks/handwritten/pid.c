/* The PID of mfcontrol.laws.pid written by hand, as a firmware engineer would: the
 * baseline of benchmarks/bench_c_export.py for the exported PID's cost.
 *
 * The same bits as the export at the nominal period: every coefficient the law computes
 * from the parameters and h (ki h, h / Tt, the derivative's ad and bd, the measurement
 * filter's c and 1 + c (h + Tf)) is computed once, when the parameters are set, by the
 * same operations; the step then does the law's remaining arithmetic in its order. Its
 * guard: a non-finite measurement or setpoint, or a step whose results are not finite,
 * returns the last output and is counted, the memory written only after the check (no
 * backup). It has no manual mode, no restart and no dropout handling (the period is
 * always h), which the export has. */
#include <math.h>
#include "pid.h"

void hpid_init(hpid *s, const hpid_params *p)
{
    double td = p->kd != 0.0 ? p->kd / p->kp : 0.0;
    s->p = *p;
    s->kih = p->ki * p->h;
    s->htt = p->h / p->tt;
    s->ad = p->kd != 0.0 ? td / (td + p->n * p->h) : 0.0;
    s->bd = p->kd != 0.0 ? ((p->kp * td) * p->n) / (td + p->n * p->h) : 0.0;
    s->fc = p->tf > 0.0 ? (2.0 * p->h) / (p->tf * p->tf) : 0.0;
    s->fden = 1.0 + s->fc * (p->h + p->tf);
    s->i = 0.0;
    s->d = 0.0;
    s->y_old = 0.0;
    s->r_old = 0.0;
    s->yf = 0.0;
    s->yf_d = 0.0;
    s->last = 0.0;
    s->started = 0;
    s->nan_count = 0;
}

double hpid_step(hpid *s, double y, double r)
{
    double p, d = 0.0, v, u, i, x = s->yf, xd = s->yf_d, y_old = s->y_old,
        r_old = s->r_old;
    if (!isfinite(y) || !isfinite(r)) {
        s->nan_count++;
        return s->last;
    }
    if (!s->started) {
        y_old = y;
        r_old = r;
        x = y;
        xd = 0.0;
    }
    if (s->p.tf > 0.0) {
        xd = (xd + s->fc * (y - x)) / s->fden;
        y = x + s->p.h * xd;
    }
    p = s->p.kp * (s->p.b * r - y);
    if (s->p.kd != 0.0) {
        double de = s->p.c == 0.0 ? y - y_old
                                  : (y - s->p.c * r) - (y_old - s->p.c * r_old);
        d = s->ad * s->d - s->bd * de;
    }
    v = (p + s->i) + d;
    u = v > s->p.out_max ? s->p.out_max : (v < s->p.out_min ? s->p.out_min : v);
    i = (s->i + s->kih * (r - y)) + s->htt * (u - v);
    if (!isfinite(u) || !isfinite(i) || !isfinite(d) || !isfinite(y) || !isfinite(xd)) {
        s->nan_count++;
        return s->last;
    }
    s->i = i;
    s->d = d;
    s->y_old = y;
    s->r_old = r;
    s->yf = y;
    s->yf_d = xd;
    s->started = 1;
    s->last = u;
    return u;
}
