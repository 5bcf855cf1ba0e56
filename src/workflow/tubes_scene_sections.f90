!> The sections scene (docs/usage.md, docs/output.md /sections) as one procedure of the core: one
!> Poincare map of the section at an excess energy, its console line and its verdict, in a result
!> record (tubes_record) that the program's driver writes (src/io/tubes_record_write.c) and
!> Python's poincare reads. The driver calls it once per &sections de, each record written before
!> the next map starts (the console keeps its order); /section itself is the driver's, shared with
!> the tubes scene.
module tubes_scene_sections
  use tubes_kinds, only: wp, i8
  use tubes_cstrings, only: num
  use tubes_record, only: record_t, EXIT_NUMERIC, EXIT_PARTIAL
  use tubes_setup, only: scene_dissipation, dissipation_attrs
  use tubes_study, only: study_t, section_choice_t, seed_stores_t, maps_at
  use tubes_scene_text, only: itoa, wall, progress_line
  use tubes_config, only: tubes_config_t
  use tubes_settings, only: settings_study, settings_section
  implicit none
  private

  public :: scene_sections

contains

  !> Map k (0-based: group /sections/map_k) of the study's section at excess energy de: n_seeds
  !> trajectories, n_iter returns each within t_max per return; dissipative: the model loses
  !> energy (said on the console, and the dissipation's attributes on the map). stores: the run's kept
  !> results (or null). rec: the map's record.
  !> Map k (0-based) of the scene on the run's settings cfg (&sections de(k + 1), n_seeds, n_iter,
  !> t_max), the saddle and the method the run chose; dissipative: the run's model dissipates.
  subroutine scene_sections(cfg, saddle, method, k, dissipative, stores, rec)
    type(tubes_config_t), intent(in) :: cfg
    character(*), intent(in) :: saddle
    integer, intent(in) :: method, k
    logical, intent(in) :: dissipative
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    call sections_scene_body(settings_study(cfg, saddle, method), settings_section(cfg), cfg%pm_de(k + 1), k, &
                             cfg%pm_n_seeds, cfg%pm_n_iter, cfg%pm_t_max, dissipative, stores, rec)
  end subroutine scene_sections

  subroutine sections_scene_body(st, sec, de, k, n_seeds, n_iter, t_max, dissipative, stores, rec)
    use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
    type(study_t), intent(in) :: st
    type(section_choice_t), intent(in) :: sec
    real(wp), intent(in) :: de, t_max
    integer, intent(in) :: k, n_seeds, n_iter
    logical, intent(in) :: dissipative
    type(seed_stores_t), pointer, intent(in) :: stores
    type(record_t), intent(inout) :: rec
    real(wp), allocatable :: pts(:, :, :)
    character(:), allocatable :: line, group
    character(8) :: name
    real(wp) :: t0
    integer :: stat, ierr
    t0 = wall()
    allocate (pts(2, n_iter, n_seeds), stat=ierr)
    if (ierr /= 0) then
      call rec%verdict(EXIT_NUMERIC, 'tubes: sections: cannot allocate ' // num(16.0_wp*n_seeds*n_iter/1e9_wp, '.3g') // &
                       ' GB for the map at dE = ' // num(de) // ' (n_seeds x n_iter = ' // itoa(n_seeds) // ' x ' // &
                       itoa(n_iter) // '): Cannot allocate memory')
      return
    end if
    line = 'sections: Poincare map at dE = ' // num(de) // ' (' // itoa(n_seeds) // ' trajectories, ' // &
           itoa(n_iter) // ' returns)...'
    call progress_line(line, .false.)
    if (associated(stores)) then
      call maps_at(st, sec, de, n_seeds, n_iter, t_max, pts, stat, stores)
    else
      call maps_at(st, sec, de, n_seeds, n_iter, t_max, pts, stat)
    end if
    if (stat < 0) call rec%verdict(EXIT_PARTIAL, 'tubes: sections: the map at dE = ' // num(de) // ' failed (status ' // &
                                   itoa(stat) // '); the returns found are written')
    line = 'sections: dE = ' // num(de) // ': ' // itoa(count(.not. ieee_is_nan(pts(1, :, :)), kind=i8)) // ' returns of ' // &
           itoa(n_seeds) // ' trajectories'
    if (dissipative) line = line // ' of the dissipative model (released at dE; each return has less energy)'
    call rec%out(line // ' (' // num(wall() - t0, '.1f') // ' s)')
    write (name, '(a, i3.3)') 'map_', k
    group = 'sections/' // trim(name)
    ! (s, p_s) of return j of seed i at [i, j, :]: pts' own memory order is the file's C order
    call rec%real(group, 'points', reshape(pts, [2*n_iter*n_seeds]), [n_seeds, n_iter, 2])
    call rec%attr_real(group, 'dE', de)
    call rec%attr_int(group, 'status', stat)
    if (dissipative) call dissipation_attrs(scene_dissipation(trim(st%system), st%params), group, rec)
  end subroutine sections_scene_body
end module tubes_scene_sections
