/* The hand-written PID of pid.c (the baseline of benchmarks/bench_c_export.py). */
#ifndef HPID_H
#define HPID_H

typedef struct {
    double kp, ki, kd, n, b, c, tf, tt, out_min, out_max;
    double h; /* the sample period (s) */
} hpid_params;

typedef struct {
    hpid_params p;
    double kih, htt, ad, bd, fc, fden; /* coefficients, from the parameters and h */
    double i, d, y_old, r_old, yf, yf_d, last;
    int started;
    unsigned long nan_count;
} hpid;

void hpid_init(hpid *s, const hpid_params *p);
double hpid_step(hpid *s, double y, double r);

#endif
