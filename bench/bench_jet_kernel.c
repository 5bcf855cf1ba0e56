/* The Taylor kernel alone (docs/integrators-taylor.md "Where the lanes' time goes"): loads one
 * cached kernel library (~/.cache/tubes/expr_<hash>.so, a jet: it has tubes_jet_lanes) and times
 * 200,000 calls at the benchmark's start (each lane's order-0 coefficients set before each call,
 * as the lanes' driver does), best of 5; prints ns per call and per lane-step.
 *   cc -O2 -o /tmp/bench_jet_kernel bench/bench_jet_kernel.c -ldl
 *   for f in ~/.cache/tubes/expr_*.so; do nm -D $f | grep -q tubes_jet_lanes && /tmp/bench_jet_kernel $f; done */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
typedef int (*jet_fn)(int, const double *, double *, double *);
static double now(void){struct timespec t; clock_gettime(CLOCK_MONOTONIC,&t); return t.tv_sec+1e-9*t.tv_nsec;}
int main(int argc, char **argv){
  if (argc < 2) { fprintf(stderr, "usage: %s KERNEL.so (a path with a slash)\n", argv[0]); return 2; }
  void *h = dlopen(argv[1], RTLD_NOW); if(!h){puts(dlerror());return 1;}
  jet_fn f = (jet_fn)dlsym(h,"tubes_jet");
  int L = *(int*)dlsym(h,"tubes_jet_lanes"), nw = *(int*)dlsym(h,"tubes_jet_nwork"), n = *(int*)dlsym(h,"tubes_jet_dim");
  int p = *(int*)dlsym(h,"tubes_jet_order"), s = p+1;
  double par[2]={0,0};
  double *tc = calloc(n*s*L,8), *w = calloc(nw*s*L,8);
  double x0[4]={4.0,12.614863819914357,0,0};
  int N = 200000;
  double best=1e9;
  for(int r=0;r<5;r++){
    double t0=now();
    for(int it=0;it<N;it++){
      for(int i=0;i<n;i++) for(int l=0;l<L;l++) tc[(i*s)*L+l]=x0[i]+1e-3*l;
      f(p,par,tc,w);
    }
    double dt=(now()-t0)/N; if(dt<best)best=dt;
  }
  printf("lanes %d dim %d nwork %d order %d: %.1f ns per call, %.1f ns per lane-step\n",L,n,nw,p,best*1e9,best*1e9/L);
  return 0;
}
