// The machine's own cycle-to-cycle spread (#26, target 3): fixed C++ work timed per "cycle" in
// thread CPU time, p99/median, as benchmarks/machine_spread.py builds and runs it.
//
//   machine_spread MODEL.bin MODE CYCLES TARGET_US [OUT.txt]
//
// MODE: pin       forwardKinematics + crba + nonLinearEffects + computeJointJacobians +
//                 updateFramePlacements on the model (pinocchio's binary serialisation), repeated
//                 to TARGET_US, q moving a little each cycle
//       alu       a chain of dependent multiply-adds (no memory traffic: the core's own speed)
//       chase<KB> a pointer chase over a random cycle of KB kilobytes, one hop per 64-byte line
//                 (256: in the core's 1 MB L2; 4096-16384: in the shared L3; 65536: memory)
// Each cycle's thread time and whether the thread was preempted in it (involuntary switches);
// "calm": neither the cycle nor the one before was preempted (the caches not emptied by
// another process).
#include <pinocchio/multibody.hpp>
#include <pinocchio/serialization.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <sys/resource.h>
#include <time.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

static long now_ns(clockid_t c) { timespec t; clock_gettime(c, &t); return t.tv_sec * 1000000000L + t.tv_nsec; }

static double pct(std::vector<double> x, double p) {
  std::sort(x.begin(), x.end());
  return x[(size_t)std::floor(p / 100 * (x.size() - 1))];
}

int main(int argc, char** argv) {
  if (argc < 5) { fprintf(stderr, "usage: %s MODEL.bin MODE CYCLES TARGET_US [OUT.txt]\n", argv[0]); return 2; }
  const char* mode = argv[2];
  const int n = atoi(argv[3]);
  const double target = atof(argv[4]);
  pinocchio::Model model;
  model.loadFromBinary(argv[1]);
  pinocchio::Data data(model);
  Eigen::VectorXd q0 = pinocchio::neutral(model), q = q0, v = Eigen::VectorXd::Constant(model.nv, 0.1),
                  a = Eigen::VectorXd::Zero(model.nv);
  volatile double sink = 0;
  const long chase_kb = !strncmp(mode, "chase", 5) ? atol(mode + 5) : 0;
  const size_t lines = chase_kb * 1024 / 64;
  std::vector<uint32_t> next(lines * 16 + 16);
  uint32_t cur = 0;
  if (chase_kb) {
    std::vector<uint32_t> perm(lines);
    for (size_t i = 0; i < lines; i++) perm[i] = i;
    srand(1);
    for (size_t i = lines - 1; i > 0; i--) std::swap(perm[i], perm[rand() % (i + 1)]);
    for (size_t i = 0; i < lines; i++) next[perm[i] * 16] = perm[(i + 1) % lines] * 16;
  }
  auto work = [&](int k, int reps) {
    if (!strcmp(mode, "pin")) {
      for (int i = 7; i < model.nq; i++) q[i] = q0[i] + 0.1 * std::sin(1e-3 * k + i);
      for (int r = 0; r < reps; r++) {
        pinocchio::forwardKinematics(model, data, q, v, a);
        pinocchio::crba(model, data, q);
        pinocchio::nonLinearEffects(model, data, q, v);
        pinocchio::computeJointJacobians(model, data, q);
        pinocchio::updateFramePlacements(model, data);
        sink = sink + data.M(0, 0);
      }
    } else if (chase_kb) {
      for (long r = 0; r < reps * 1000L; r++) cur = next[cur];
      sink = sink + cur;
    } else {
      double x = 1.0 + 1e-9 * k;
      for (long r = 0; r < reps * 1000L; r++) x = x * 0.9999999 + 1e-7;
      sink = sink + x;
    }
  };
  // one unit's median over 51 warm calls sets the repetitions for TARGET_US
  for (int k = 0; k < 200; k++) work(k, 1);
  std::vector<double> one;
  for (int k = 0; k < 51; k++) {
    long c0 = now_ns(CLOCK_THREAD_CPUTIME_ID);
    work(k, 1);
    one.push_back((now_ns(CLOCK_THREAD_CPUTIME_ID) - c0) / 1e3);
  }
  const int reps = std::max(1, (int)std::lround(target / pct(one, 50)));
  for (int k = 0; k < 200; k++) work(k, reps);
  std::vector<double> th(n);
  std::vector<long> sw(n);
  for (int k = 0; k < n; k++) {
    rusage r0, r1;
    getrusage(RUSAGE_THREAD, &r0);
    long c0 = now_ns(CLOCK_THREAD_CPUTIME_ID);
    work(k, reps);
    th[k] = (now_ns(CLOCK_THREAD_CPUTIME_ID) - c0) / 1e3;
    getrusage(RUSAGE_THREAD, &r1);
    sw[k] = r1.ru_nivcsw - r0.ru_nivcsw;
  }
  std::vector<double> calm;
  long preempted = 0;
  for (int k = 0; k < n; k++) {
    preempted += sw[k] > 0;
    if (sw[k] == 0 && (k == 0 || sw[k - 1] == 0)) calm.push_back(th[k]);
  }
  const double m = pct(th, 50), p = pct(th, 99), cm = pct(calm, 50), cp = pct(calm, 99);
  printf("%-10s thread median %6.1f us p99 %6.1f (%.2fx); calm %.2fx; p90/median %.2f; %ld of %d preempted\n", mode, m, p,
         p / m, cp / cm, pct(th, 90) / m, preempted, n);
  if (argc > 5) {
    FILE* f = fopen(argv[5], "w");
    for (int k = 0; k < n; k++) fprintf(f, "%.3f %ld\n", th[k], sw[k]);
    fclose(f);
  }
  return 0;
}
