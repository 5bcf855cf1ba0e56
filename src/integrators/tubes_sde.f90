!> The stochastic integrator of a noisy field (tubes_hamiltonian damped_t with noise or
!> temperature): dx = f(x) dt + [0; S(q) dW], additive noise on the momenta with a factor that
!> depends on the coordinates only. Each step is an RK4 step of the drift (tubes_rk4: fixed step h,
!> the step grid, cubic Hermite dense output between the step's ends) followed by the noise's
!> increment S(q_n) dW_n, dW_n = sqrt(h) z, z normal deviates of the counter-based generator
!> (tubes_philox) at counter (step number, stream, 0, 0) and key (the field's seed, 0): the path of
!> trajectory `stream` does not depend on threads, ranks or the order of integration. Strong order
!> 1 (noise only in p, S independent of p: the Milstein correction vanishes; the drift's error is
!> RK4's), measured in tests/test_noise.f90. docs/dissipation.md, "Noise".
module tubes_sde
  use, intrinsic :: iso_fortran_env, only: int64
  use tubes_kinds, only: wp, i8
  use tubes_rk4, only: rk4_t
  use tubes_philox, only: philox_normals, I16
  use tubes_hamiltonian, only: damped_t
  use tubes_integrator, only: all_finite
  use tubes_status, only: TUBES_OK, TUBES_EMODEL, TUBES_EINPUT
  implicit none
  private

  type, extends(rk4_t), public :: sde_t
    integer(int64) :: stream = 0      !! the trajectory's number (the generator's counter word 2)
    !> a given Brownian path instead of the generator's (tests: paths nested across step sizes):
    !> column n the increment dW of step n (N components)
    real(wp), allocatable :: dw(:, :)
  contains
    procedure :: step => sde_step
  end type sde_t

  public :: sde_increment

contains

  !> One step: RK4 of the drift, then the noise's increment at the step's start (S(q_old) dW).
  subroutine sde_step(self, x, tmax, stat)
    class(sde_t), intent(inout) :: self
    real(wp), intent(inout) :: x(:)
    real(wp), intent(in) :: tmax
    integer, intent(out) :: stat
    real(wp) :: h, dx(size(x))
    integer :: fs
    call self%rk4_t%step(x, tmax, stat)
    if (stat /= TUBES_OK) return
    h = self%t - self%t_old
    select type (f => self%f)
    type is (damped_t)
      if (allocated(self%dw)) then
        call sde_increment(f, self%x_old, abs(h), [int(self%nsteps, I16), int(self%stream, I16), 0_I16, 0_I16], &
                           dx, stat, self%dw(:, self%nsteps))
      else
        call sde_increment(f, self%x_old, abs(h), [int(self%nsteps, I16), int(self%stream, I16), 0_I16, 0_I16], &
                           dx, stat)
      end if
    class default
      stat = TUBES_EINPUT
    end select
    if (stat /= TUBES_OK) return
    x = x + dx
    self%x_new = x
    call self%f%eval(self%t, x, self%f_cur, fs)      ! the end slope at the noisy end
    self%nfev = self%nfev + 1
    if (fs /= 0 .or. .not. (all_finite(x) .and. all_finite(self%f_cur))) stat = TUBES_EMODEL
  end subroutine sde_step

  !> The noise's increment of a step of length h from x: [0; S(q) sqrt(h) z], z the first N of the
  !> generator's four normals at counter ctr (N <= 4) and key (seed, 0).
  subroutine sde_increment(f, x, h, ctr, dx, stat, dw)
    type(damped_t), intent(in) :: f
    real(wp), intent(in) :: x(:), h
    integer(I16), intent(in) :: ctr(4)
    real(wp), intent(out) :: dx(:)
    integer, intent(out) :: stat
    real(wp), intent(in), optional :: dw(:)     !! the increment dW itself (no generator)
    real(wp) :: s(size(x)/2, size(x)/2), z(4)
    integer :: n
    n = size(x)/2
    dx = 0
    stat = TUBES_EINPUT
    if (n > 4) return
    call f%noise_factor(x, s, stat)
    if (stat /= 0) then
      stat = TUBES_EMODEL
      return
    end if
    if (present(dw)) then
      dx(n + 1:2*n) = matmul(s, dw(1:n))
    else
      z = philox_normals(ctr, [int(f%seed, I16), 0_I16])
      dx(n + 1:2*n) = matmul(s, sqrt(h)*z(1:n))
    end if
    stat = TUBES_OK
  end subroutine sde_increment
end module tubes_sde
