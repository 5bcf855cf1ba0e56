!> Noise (src/base/tubes_philox.f90, src/integrators/tubes_sde.f90): the counter-based generator's
!> words against numpy's Philox4x64-10 (numpy.random.Philox(key=k, counter=c) gives philox(c + 1, k)
!> first: values printed by numpy 2.x), its normals' moments, and the stochastic integrator's strong
!> order of convergence on nested Brownian paths (a damped Henon-Heiles well with additive noise).
program test_noise
  use, intrinsic :: iso_fortran_env, only: int64
  use tubes_kinds, only: wp
  use tubes_check, only: check_close, check_true, check_eq, finish
  use tubes_status, only: TUBES_OK
  use tubes_philox, only: philox4x64, philox_normals, I16
  use tubes_henon_heiles, only: henon_heiles_t
  use tubes_hamiltonian, only: damped_t, make_damped
  use tubes_sde, only: sde_t
  use tubes_integrator, only: propagate
  implicit none
  integer(I16) :: w(4)
  real(wp) :: z(4), s1, s2, s4, err(5), rate
  integer :: k, n
  ! numpy: Philox(key=0, counter=2**256 - 1).random_raw(4) (the counter wraps to 0)
  w = philox4x64([0_I16, 0_I16, 0_I16, 0_I16], [0_I16, 0_I16])
  call check_true('philox(0; 0) word 1 = numpy''s 16554D9ECA36314C', w(1) == int(z'16554D9ECA36314C', I16))
  call check_true('philox(0; 0) word 4 = numpy''s 7E68B68AEC7BA23B', w(4) == int(z'7E68B68AEC7BA23B', I16))
  ! numpy: Philox(key=12345, counter=0).random_raw(4)
  w = philox4x64([1_I16, 0_I16, 0_I16, 0_I16], [12345_I16, 0_I16])
  call check_true('philox(1; 12345) = numpy''s A5792C0A0ED6A560 .. 28DB5404D83FAC91', &
                  all(w == [int(z'A5792C0A0ED6A560', I16), int(z'C63666BA8B756514', I16), &
                            int(z'C953E311F634209D', I16), int(z'28DB5404D83FAC91', I16)]))
  ! normals: mean 0, variance 1, fourth moment 3 over 4 x 100,000 deviates (standard errors
  ! 1.6e-3, 2.2e-3, 1.6e-2: 5 of them allowed)
  s1 = 0; s2 = 0; s4 = 0
  n = 100000
  do k = 1, n
    z = philox_normals([int(k, I16), 7_I16, 0_I16, 0_I16], [99_I16, 0_I16])
    s1 = s1 + sum(z)
    s2 = s2 + sum(z**2)
    s4 = s4 + sum(z**4)
  end do
  call check_close('normals: mean', s1/(4*n), 0.0_wp, 5*1.6e-3_wp)
  call check_close('normals: variance', s2/(4*n), 1.0_wp, 5*2.2e-3_wp)
  call check_close('normals: fourth moment', s4/(4*n), 3.0_wp, 5*1.6e-2_wp)
  call strong_order(err)
  do k = 2, 5
    rate = log(err(k - 1)/err(k))/log(2.0_wp)
    write (*, '(a, i0, a, es10.3, a, f6.3)') 'h = 2^-', k + 3, ': strong error ', err(k), ', observed order ', rate
  end do
  ! strong order 1 (docs/dissipation.md): the observed rate of the finer halvings
  rate = log(err(2)/err(5))/(3*log(2.0_wp))
  call check_close('strong order (h = 2^-5 .. 2^-8)', rate, 1.0_wp, 0.15_wp)
  call finish('test_noise')
contains
  !> The mean over M paths of |x_h(T) - x_ref(T)| (max norm) at T = 1 for h = 2^-4 .. 2^-8, the
  !> reference at 2^-12, all on the same Brownian path (increments of the finest grid summed).
  subroutine strong_order(err)
    real(wp), intent(out) :: err(5)
    integer, parameter :: M = 100, LREF = 12
    type(henon_heiles_t) :: hh
    type(damped_t) :: f
    real(wp), allocatable :: dwf(:, :)
    real(wp) :: xr(4), xh(4), x0(4)
    integer :: j, l, nf, i
    call make_damped(f, hh, 0.5_wp)
    f%noise = 0.05_wp
    nf = 2**LREF
    err = 0
    x0 = [0.1_wp, -0.05_wp, 0.0_wp, 0.2_wp]
    do j = 1, M
      allocate (dwf(2, nf))
      do i = 1, nf            ! the finest path's increments, sqrt(h_f) z
        z = philox_normals([int(i, I16), int(j, I16), 0_I16, 0_I16], [2026_I16, 0_I16])
        dwf(:, i) = sqrt(1.0_wp/nf)*z(1:2)
      end do
      xr = run(f, dwf, LREF, x0)
      do l = 4, 8
        xh = run(f, dwf, l, x0)
        err(l - 3) = err(l - 3) + maxval(abs(xh - xr))/M
      end do
      deallocate (dwf)
    end do
  end subroutine strong_order

  !> The stochastic integrator to t = 1 with step 2^-lev on the path dwf (finest increments summed).
  function run(f, dwf, lev, x0) result(x)
    type(damped_t), intent(in) :: f
    real(wp), intent(in) :: dwf(:, :), x0(4)
    integer, intent(in) :: lev
    real(wp) :: x(4)
    type(sde_t) :: ig
    integer :: q, m2, ns, st
    ns = 2**lev
    m2 = size(dwf, 2)/ns
    call ig%init(f, 0.0_wp)
    ig%h = 1.0_wp/ns
    allocate (ig%dw(2, ns))
    do q = 1, ns
      ig%dw(:, q) = sum(dwf(:, (q - 1)*m2 + 1:q*m2), dim=2)
    end do
    x = x0
    call propagate(ig, x, 1.0_wp, st)
    if (st /= TUBES_OK) x = huge(1.0_wp)
  end function run
end program test_noise
