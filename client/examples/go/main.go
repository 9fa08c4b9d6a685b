// A soilvol client in Go, with stubs generated from proto/soilvol/v1/soilvol.proto by Debian's
// protoc-gen-go and protoc-gen-go-grpc (see README.md): server info, register a container from
// an empty scan, estimate a scan with an idempotency key, page through the containers, and
// read the google.rpc.Status details of an error.
package main

import (
	"context"
	"errors"
	"flag"
	"fmt"
	"log"
	"os"
	"strconv"
	"strings"
	"time"

	"google.golang.org/genproto/googleapis/rpc/errdetails"
	"google.golang.org/grpc"
	"google.golang.org/grpc/metadata"
	"google.golang.org/grpc/status"

	soilvolv1 "soilvol.dev/api/soilvol/v1"
)

// corners parses "x,y,z;x,y,z;x,y,z;x,y,z" (metres, scan frame) into the opening.
func corners(text string) (*soilvolv1.Opening, error) {
	opening := &soilvolv1.Opening{}
	for _, corner := range strings.Split(text, ";") {
		xyz := strings.Split(corner, ",")
		if len(xyz) != 3 {
			return nil, fmt.Errorf("corner %q is not x,y,z", corner)
		}
		var v [3]float64
		for i, s := range xyz {
			f, err := strconv.ParseFloat(strings.TrimSpace(s), 64)
			if err != nil {
				return nil, fmt.Errorf("corner %q: %v", corner, err)
			}
			v[i] = f
		}
		opening.Corners = append(opening.Corners, &soilvolv1.Point3{X: v[0], Y: v[1], Z: v[2]})
	}
	return opening, nil
}

// explain prints what a failed call's google.rpc.Status says: code, message, field, reason.
func explain(err error) {
	st := status.Convert(err)
	fmt.Printf("error: %s: %s\n", st.Code(), st.Message())
	for _, detail := range st.Details() {
		switch d := detail.(type) {
		case *errdetails.ErrorInfo:
			fmt.Printf("  reason %s (domain %s), field %q\n", d.Reason, d.Domain, d.Metadata["field"])
		case *errdetails.BadRequest:
			for _, v := range d.FieldViolations {
				fmt.Printf("  bad field %s: %s\n", v.Field, v.Description)
			}
		case *errdetails.RetryInfo:
			fmt.Printf("  retry after %s\n", d.RetryDelay.AsDuration())
		}
	}
}

func main() {
	server := flag.String("server", "localhost:50051", "soilvol-server gRPC address")
	id := flag.String("id", "go-example", "container id")
	empty := flag.String("empty", "", "PLY or PCD file of the empty container")
	opening := flag.String("corners", "", "opening corners x,y,z;x,y,z;x,y,z;x,y,z")
	scan := flag.String("scan", "", "PLY or PCD file of the filled container")
	flag.Parse()
	if *empty == "" || *opening == "" || *scan == "" {
		log.Fatal("usage: soilvol-go-example -server host:port -empty empty.ply -corners '...' -scan scan.ply")
	}

	conn, err := grpc.Dial(*server, grpc.WithInsecure()) // Debian's grpc-go 1.33: no credentials/insecure yet
	if err != nil {
		log.Fatal(err)
	}
	defer conn.Close()
	client := soilvolv1.NewSoilVolumeClient(conn)
	ctx, cancel := context.WithTimeout(context.Background(), 60*time.Second)
	defer cancel()
	ctx = metadata.AppendToOutgoingContext(ctx, "x-request-id", "go-example-1")

	info, err := client.GetServerInfo(ctx, &soilvolv1.GetServerInfoRequest{})
	if err != nil {
		log.Fatal(err)
	}
	fmt.Printf("server %s (%s)\n", info.Version, info.Revision)

	emptyBytes, err := os.ReadFile(*empty)
	if err != nil {
		log.Fatal(err)
	}
	open, err := corners(*opening)
	if err != nil {
		log.Fatal(err)
	}
	container, err := client.RegisterContainer(ctx, &soilvolv1.RegisterContainerRequest{
		ContainerId: *id,
		Overwrite:   true,
		Scan:        &soilvolv1.Scan{Source: &soilvolv1.Scan_Cloud{Cloud: &soilvolv1.CloudScan{Data: emptyBytes}}},
		Opening:     open,
	})
	if err != nil {
		explain(err)
		os.Exit(1)
	}
	fmt.Printf("registered %s: struck capacity %.1f L, etag %s\n", container.ContainerId,
		1000*container.StruckCapacityM3, container.Etag)

	scanBytes, err := os.ReadFile(*scan)
	if err != nil {
		log.Fatal(err)
	}
	estimate, err := client.EstimateVolume(ctx, &soilvolv1.EstimateVolumeRequest{
		ContainerId:         *id,
		Scan:                &soilvolv1.Scan{Source: &soilvolv1.Scan_Cloud{Cloud: &soilvolv1.CloudScan{Data: scanBytes}}},
		RequestId:           "go-load-1",
		MaterialDensityKgM3: proto64(1600),
	})
	if err != nil {
		explain(err)
		os.Exit(1)
	}
	fmt.Printf("volume %.1f L +- %.1f L, mass %.0f kg\n", 1000*estimate.VolumeM3,
		1000*estimate.UncertaintyM3, estimate.GetMassKg())

	pageToken, count := "", 0
	for {
		page, err := client.ListContainers(ctx, &soilvolv1.ListContainersRequest{PageSize: 2, PageToken: pageToken})
		if err != nil {
			log.Fatal(err)
		}
		count += len(page.Containers)
		if pageToken = page.NextPageToken; pageToken == "" {
			break
		}
	}
	fmt.Printf("containers: %d\n", count)

	// A mistake on purpose: the error names the field.
	_, err = client.EstimateVolume(ctx, &soilvolv1.EstimateVolumeRequest{
		ContainerId: *id, GridCellM: proto64(0),
		Scan: &soilvolv1.Scan{Source: &soilvolv1.Scan_Cloud{Cloud: &soilvolv1.CloudScan{Data: scanBytes}}},
	})
	if err == nil {
		log.Fatal(errors.New("a zero grid cell was accepted"))
	}
	explain(err)
}

func proto64(v float64) *float64 { return &v }
